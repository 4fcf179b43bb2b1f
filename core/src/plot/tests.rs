//! Tests of the plots: files written, bad input, and pixels of the drawn
//! figures (rendered into memory).

use std::fs;
use std::path::{Path, PathBuf};

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::lines::draw_lines;
use super::map::*;
use super::*;

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("plot_test_{}_{name}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

fn assert_png(path: &Path) {
    let bytes = fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert!(
        bytes.len() > 5000,
        "suspiciously small PNG: {}",
        bytes.len()
    );
}

fn convergence() -> Vec<Series> {
    let h: Vec<f64> = (0..6).map(|i| 0.1 / 2f64.powi(i)).collect();
    vec![
        Series {
            label: "L2 error (displacement)".into(),
            points: h.iter().map(|&h| (h, 0.8 * h * h)).collect(),
        },
        Series {
            label: "energy error".into(),
            points: h.iter().map(|&h| (h, 0.3 * h)).collect(),
        },
    ]
}

#[test]
fn loglog_two_series_writes_png() {
    let dir = tmp_dir("loglog");
    let p = dir.join("conv.png");
    loglog(&p, "Convergence", "h", "error", &convergence()).unwrap();
    assert_png(&p);
    let names: Vec<_> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("conv.png")]);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn lines_two_series_writes_png() {
    let dir = tmp_dir("lines");
    let p = dir.join("ts.png");
    let s = vec![
        Series {
            label: "pressure".into(),
            points: (0..500)
                .map(|i| (i as f64 * 0.01, (i as f64 * 0.03).sin()))
                .collect(),
        },
        Series {
            label: "aperture".into(),
            points: (0..500)
                .map(|i| (i as f64 * 0.01, 0.5 * (i as f64 * 0.01)))
                .collect(),
        },
    ];
    lines(&p, "Time series", "t [s]", "value", &s).unwrap();
    assert_png(&p);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn degenerate_input_does_not_panic() {
    let dir = tmp_dir("degenerate");
    let bad = vec![
        Series {
            label: "negative".into(),
            points: vec![(-1.0, 2.0), (1.0, -3.0), (0.0, 0.0), (f64::NAN, 1.0)],
        },
        Series {
            label: "empty".into(),
            points: vec![],
        },
    ];
    loglog(&dir.join("a.png"), "all dropped", "x", "y", &bad).unwrap();
    assert_png(&dir.join("a.png"));
    loglog(&dir.join("b.png"), "no series", "x", "y", &[]).unwrap();
    lines(&dir.join("c.png"), "no series", "x", "y", &[]).unwrap();
    let single = vec![Series {
        label: "one point".into(),
        points: vec![(3.0, 3.0), (3.0, 3.0)],
    }];
    loglog(&dir.join("d.png"), "single", "x", "y", &single).unwrap();
    lines(&dir.join("e.png"), "single", "x", "y", &single).unwrap();
    let huge = vec![Series {
        label: String::new(),
        points: vec![(-f64::MAX, 0.0), (f64::MAX, 1e-300), (0.0, f64::INFINITY)],
    }];
    lines(&dir.join("f.png"), "huge", "x", "y", &huge).unwrap();
    let many: Vec<Series> = (0..25)
        .map(|i| Series {
            label: format!("s{i}"),
            points: vec![(1.0, 1.0 + i as f64), (1e12, 1e-12 * (1.0 + i as f64))],
        })
        .collect();
    loglog(&dir.join("g.png"), "many", "x", "y", &many).unwrap();
    for f in ["b.png", "c.png", "d.png", "e.png", "f.png", "g.png"] {
        assert_png(&dir.join(f));
    }
    fs::remove_dir_all(&dir).unwrap();
}

/// Deterministic pseudo-random numbers in 0..1.
fn rng(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

/// `n` random segments in two orientation families over 200 m x 120 m.
fn random_network(n: usize, seed: u64) -> Vec<Segment> {
    let mut s = seed;
    (0..n)
        .map(|i| {
            let (cx, cy) = (200.0 * rng(&mut s), 120.0 * rng(&mut s));
            let base = if i % 2 == 0 { 30f64 } else { 115.0 };
            let ang = (base + 20.0 * (rng(&mut s) - 0.5)).to_radians();
            let half = 0.5 * (5.0 + 35.0 * rng(&mut s));
            let (dx, dy) = (half * ang.cos(), half * ang.sin());
            Segment {
                a: [cx - dx, cy - dy],
                b: [cx + dx, cy + dy],
            }
        })
        .collect()
}

fn only_file(dir: &Path, name: &str) {
    let names: Vec<_> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from(name)]);
}

#[test]
fn network_random_linear_and_log_write_png() {
    let dir = tmp_dir("network");
    let segs = random_network(200, 7);
    let mut s = 99;
    let mut lin: Vec<f64> = segs.iter().map(|g| 1e7 - 2e4 * g.a[0]).collect();
    lin[3] = f64::NAN;
    lin[4] = f64::INFINITY;
    let p = dir.join("lin.png");
    let none: &[([f64; 2], &str)] = &[];
    network(
        &p,
        "Pressure",
        &segs,
        &lin,
        "p [Pa]",
        ColourScale::Linear,
        None,
        none,
    )
    .unwrap();
    assert_png(&p);
    only_file(&dir, "lin.png");

    let mut q: Vec<f64> = (0..segs.len())
        .map(|_| 10f64.powf(-9.0 + 5.0 * rng(&mut s)))
        .collect();
    q[0] = 0.0;
    q[1] = -1e-6;
    q[2] = f64::NAN;
    let widths: Vec<f64> = q.iter().map(|v| 1.0 + (v.log10() + 9.0)).collect();
    let markers = [([20.0, 60.0], "pump"), ([180.0, 60.0], "production")];
    let p = dir.join("log.png");
    let label = "q [m³/s]";
    network(
        &p,
        "Flow",
        &segs,
        &q,
        label,
        ColourScale::Log,
        Some(&widths),
        &markers,
    )
    .unwrap();
    assert_png(&p);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn network_degenerate_input_does_not_panic() {
    let dir = tmp_dir("network_degenerate");
    let none: &[([f64; 2], &str)] = &[];
    let lin = ColourScale::Linear;
    let log = ColourScale::Log;
    network(&dir.join("a.png"), "empty", &[], &[], "v", lin, None, none).unwrap();
    network(&dir.join("b.png"), "", &[], &[], "", log, Some(&[]), none).unwrap();
    let segs = random_network(50, 3);
    let nan = vec![f64::NAN; segs.len()];
    network(
        &dir.join("c.png"),
        "all NaN",
        &segs,
        &nan,
        "v",
        lin,
        None,
        none,
    )
    .unwrap();
    let neg = vec![-1.0; segs.len()];
    network(
        &dir.join("d.png"),
        "all negative",
        &segs,
        &neg,
        "v",
        log,
        None,
        none,
    )
    .unwrap();
    let one = [Segment {
        a: [5.0, 5.0],
        b: [5.0, 5.0],
    }];
    let markers = [([5.0, 5.0], "well")];
    network(
        &dir.join("e.png"),
        "point",
        &one,
        &[2.0],
        "v",
        log,
        None,
        &markers,
    )
    .unwrap();
    let odd = [
        Segment {
            a: [f64::NAN, 0.0],
            b: [1.0, 1.0],
        },
        Segment {
            a: [0.0, 0.0],
            b: [1e3, 0.0],
        },
        Segment {
            a: [-f64::MAX, 0.0],
            b: [f64::MAX, 1e-300],
        },
    ];
    let w = [f64::NAN, 1e9, -3.0];
    let v = [1.0, 1.0, 1.0];
    network(
        &dir.join("f.png"),
        "odd",
        &odd,
        &v,
        "v",
        lin,
        Some(&w),
        none,
    )
    .unwrap();
    let far = [([f64::INFINITY, 0.0], "lost"), ([1.0, 2.0], "")];
    network(
        &dir.join("g.png"),
        "markers only",
        &[],
        &[],
        "v",
        lin,
        None,
        &far,
    )
    .unwrap();
    for f in [
        "a.png", "b.png", "c.png", "d.png", "e.png", "f.png", "g.png",
    ] {
        assert_png(&dir.join(f));
    }
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn network_length_mismatch_is_err() {
    let dir = tmp_dir("network_mismatch");
    let segs = random_network(10, 1);
    let p = dir.join("x.png");
    let none: &[([f64; 2], &str)] = &[];
    let lin = ColourScale::Linear;
    let e = network(&p, "t", &segs, &[1.0; 9], "v", lin, None, none).unwrap_err();
    assert!(matches!(e, PlotError::Input { .. }), "{e:?}");
    assert!(
        e.to_string().contains("9 values given for 10 segments"),
        "{e}"
    );
    let w = [2.0; 11];
    let e = network(&p, "t", &segs, &[1.0; 10], "v", lin, Some(&w), none).unwrap_err();
    assert!(
        e.to_string()
            .contains("11 line widths given for 10 segments"),
        "{e}"
    );
    assert_eq!(fs::read_dir(&dir).unwrap().count(), 0);
    fs::remove_dir_all(&dir).unwrap();
}

/// Example maps for looking at: written to `$PLOT_EXAMPLES_DIR` when set
/// (kept), else to a temporary folder (removed).
#[test]
fn network_examples_render() {
    let keep = std::env::var_os("PLOT_EXAMPLES_DIR").map(PathBuf::from);
    let dir = match &keep {
        Some(d) => {
            fs::create_dir_all(d).unwrap();
            d.clone()
        }
        None => tmp_dir("network_examples"),
    };

    // Grid network, 150 m x 110 m, pressure falling from left to right.
    let (nx, ny, h) = (16, 12, 10.0);
    let mut segs = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let p = [i as f64 * h, j as f64 * h];
            if i + 1 < nx {
                segs.push(Segment {
                    a: p,
                    b: [p[0] + h, p[1]],
                });
            }
            if j + 1 < ny {
                segs.push(Segment {
                    a: p,
                    b: [p[0], p[1] + h],
                });
            }
        }
    }
    let mut s = 5;
    let pressure: Vec<f64> = segs
        .iter()
        .map(|g| {
            let x = 0.5 * (g.a[0] + g.b[0]);
            2.0e7 - 5.0e6 * x / 150.0 + 1.0e5 * (rng(&mut s) - 0.5)
        })
        .collect();
    let p = dir.join("network_grid_pressure.png");
    let none: &[([f64; 2], &str)] = &[];
    let (title, lin) = ("Grid network: fluid pressure", ColourScale::Linear);
    network(
        &p,
        title,
        &segs,
        &pressure,
        "pressure [Pa]",
        lin,
        None,
        none,
    )
    .unwrap();
    assert_png(&p);

    // Random network, log-scale flow rate, widths by flow rate.
    let segs = random_network(180, 11);
    let q: Vec<f64> = segs
        .iter()
        .enumerate()
        .map(|(k, g)| match k {
            5 => f64::NAN,
            6 => 0.0,
            _ => {
                let y = 0.5 * (g.a[1] + g.b[1]);
                10f64.powf(-4.0 - 5.0 * ((y - 60.0).abs() / 60.0) - rng(&mut s))
            }
        })
        .collect();
    let widths: Vec<f64> = q.iter().map(|v| 0.8 + 1.2 * (v.log10() + 10.0)).collect();
    let markers = [([20.0, 60.0], "pump"), ([180.0, 60.0], "production")];
    let p = dir.join("network_flow_log.png");
    let (title, log) = ("Fracture network: flow rate", ColourScale::Log);
    let label = "flow rate [m³/s]";
    network(&p, title, &segs, &q, label, log, Some(&widths), &markers).unwrap();
    assert_png(&p);

    if keep.is_none() {
        fs::remove_dir_all(&dir).unwrap();
    }
}

/// Width and height from a PNG's IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let b = fs::read(path).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&b[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

/// Edges of a grid of `nx` x `ny` squares of 1 m from the origin.
fn grid_edges(nx: usize, ny: usize) -> Vec<Segment> {
    let mut e = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let p = [i as f64, j as f64];
            if i < nx {
                e.push(Segment {
                    a: p,
                    b: [p[0] + 1.0, p[1]],
                });
            }
            if j < ny {
                e.push(Segment {
                    a: p,
                    b: [p[0], p[1] + 1.0],
                });
            }
        }
    }
    e
}

/// Axis-aligned quad `[x0, x1] x [y0, y1]`.
fn rect(x0: f64, x1: f64, y0: f64, y1: f64) -> [[f64; 2]; 4] {
    [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
}

/// A big quad (value 5), a 1 mm thin one (value 1) and one without a
/// value over a 10 m x 4 m grid.
fn small_fracture_map() -> (Vec<Segment>, Vec<[[f64; 2]; 4]>, Vec<f64>) {
    let quads = vec![
        rect(1.0, 9.0, 1.0, 3.0),
        rect(2.0, 5.0, 3.5495, 3.5505),
        rect(6.0, 8.0, 3.3, 3.9),
    ];
    (grid_edges(10, 4), quads, vec![5.0, 1.0, f64::NAN])
}

/// Render a figure of `size` px into memory with `draw`: RGB pixels and
/// where data coordinates landed.
fn render(size: (u32, u32), draw: impl FnOnce(&Area) -> Drawn<Coords>) -> (Vec<u8>, Coords) {
    ensure_font().unwrap();
    let mut buf = vec![0u8; (size.0 * size.1 * 3) as usize];
    let coords = {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        let coords = draw(&root).unwrap();
        root.present().unwrap();
        coords
    };
    (buf, coords)
}

/// Render a fracture map of `quads` over `mesh` into memory.
fn render_fracture_map(
    mesh: &[Segment],
    quads: &[[[f64; 2]; 4]],
    values: &[f64],
    window: Option<[f64; 4]>,
) -> (Vec<u8>, Coords) {
    let shapes = Shapes::Quads(quads, mesh, window);
    let linear = ColourScale::Linear;
    render((NET_WIDTH, NET_HEIGHT), |root| {
        draw_map(root, ("t", "v"), &shapes, values, linear, &[])
    })
}

/// RGB of pixel `(x, y)` of an image `width` px wide.
fn pixel_of(buf: &[u8], width: u32, (x, y): (i32, i32)) -> [u8; 3] {
    let i = 3 * (y as usize * width as usize + x as usize);
    [buf[i], buf[i + 1], buf[i + 2]]
}

/// RGB of pixel `(x, y)` of a map.
fn pixel(buf: &[u8], p: (i32, i32)) -> [u8; 3] {
    pixel_of(buf, NET_WIDTH, p)
}

/// RGB of the pixel holding the point `p` (m).
fn pixel_at(buf: &[u8], coords: &Coords, p: [f64; 2]) -> [u8; 3] {
    pixel(buf, coords.translate(&(p[0], p[1])))
}

fn rgb(c: RGBColor) -> [u8; 3] {
    [c.0, c.1, c.2]
}

/// Pixel ranges of the plotting area.
fn plot_px(coords: &Coords) -> (std::ops::Range<i32>, std::ops::Range<i32>) {
    let (x, y) = (coords.get_x_range(), coords.get_y_range());
    let lo = coords.translate(&(x.start, y.start));
    let hi = coords.translate(&(x.end, y.end));
    (lo.0..hi.0 + 1, hi.1..lo.1 + 1)
}

#[test]
fn fracture_map_writes_png_of_expected_size() {
    let dir = tmp_dir("fracture_map");
    let (edges, quads, values) = small_fracture_map();
    let p = dir.join("fractures.png");
    let markers = [([1.0, 2.0], "pump"), ([500.0, 2.0], "far away")];
    let label = "pressure [MPa]";
    fracture_map(&p, "Fig. 7", &edges, &quads, &values, label, None, &markers).unwrap();
    assert_png(&p);
    assert_eq!(png_size(&p), (NET_WIDTH, NET_HEIGHT));
    only_file(&dir, "fractures.png");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn fracture_map_pixels() {
    let (edges, quads, values) = small_fracture_map();
    let (buf, c) = render_fracture_map(&edges, &quads, &values, None);
    let (fx, fy) = (c.get_x_range(), c.get_y_range());
    // Inside the big quad: the top of the colour bar.
    let top = viridis(1.0);
    assert_eq!(pixel_at(&buf, &c, [5.5, 2.5]), rgb(top));
    assert_eq!(pixel_at(&buf, &c, [1.5, 1.5]), rgb(top));
    // The quad without a value: grey.
    let g = NO_VALUE_GREY;
    assert_eq!(pixel_at(&buf, &c, [7.5, 3.6]), rgb(g));
    // The 1 mm quad (0.1 px) still shows, dark (bottom of the bar).
    let [r, gr, b] = pixel_at(&buf, &c, [3.5, 3.55]);
    assert!(gr < 128 && r < 160 && b < 180, "{r} {gr} {b}");
    // Quads cover the mesh (here a mesh node inside the big quad).
    assert_eq!(pixel_at(&buf, &c, [5.0, 2.0]), rgb(top));
    // Equal scales: 2 m across take as many pixels as 2 m up.
    let (o, e) = (c.translate(&(1.0, 1.0)), c.translate(&(3.0, 3.0)));
    assert!(((e.0 - o.0) - (o.1 - e.1)).abs() <= 1, "{o:?} {e:?}");
    // Between mesh lines outside the quads: white; on a mesh line: grey.
    assert_eq!(pixel_at(&buf, &c, [5.5, 0.5]), [255, 255, 255]);
    let [r, gr, b] = pixel_at(&buf, &c, [5.5, 4.0]);
    assert!(r == gr && gr == b && r < 250, "{r} {gr} {b}");
    // Default window: the quads' box plus 10 %, widened to the aspect ratio.
    assert!(fx.start < 0.3 && fx.end > 9.7, "{fx:?}");
    assert!(fx.end - fx.start < 11.0, "{fx:?}");
    assert!(fy.start < 1.0 && fy.end > 3.9, "{fy:?}");

    // A window shows just that region; the quads outside it are clipped.
    let window = Some([5.0, 6.0, 2.0, 2.5]);
    let (buf, c) = render_fracture_map(&edges, &quads, &values, window);
    let fx = c.get_x_range();
    assert!(fx.start <= 5.0 && fx.end >= 6.0, "{fx:?}");
    assert!(fx.end - fx.start < 1.5, "{fx:?}");
    assert_eq!(pixel_at(&buf, &c, [5.5, 2.25]), rgb(top));

    // The default window follows the quads, not the mesh.
    let big = grid_edges(100, 100);
    let q = [rect(40.0, 45.0, 50.0, 50.2)];
    let (buf, c) = render_fracture_map(&big, &q, &[2.0], None);
    let fx = c.get_x_range();
    assert!(fx.start > 35.0 && fx.end < 50.0, "{fx:?}");
    // The middle of the colour bar (up to rounding: one value only).
    let (one, mid) = (pixel_at(&buf, &c, [42.5, 50.1]), rgb(viridis(0.5)));
    assert!(
        (0..3).all(|i| one[i].abs_diff(mid[i]) <= 1),
        "{one:?} {mid:?}"
    );
}

#[test]
fn fracture_map_bad_input_is_err() {
    let dir = tmp_dir("fracture_map_bad");
    let (edges, quads, values) = small_fracture_map();
    let p = dir.join("x.png");
    let e = fracture_map(&p, "t", &edges, &quads, &values[..2], "v", None, &[]).unwrap_err();
    assert!(matches!(e, PlotError::Input { .. }), "{e:?}");
    assert!(e.to_string().contains("2 values given for 3 quads"), "{e}");
    for w in [
        [0.0, 1.0, 2.0, 2.0],
        [1.0, 0.0, 0.0, 1.0],
        [f64::NAN, 1.0, 0.0, 1.0],
        [0.0, f64::INFINITY, 0.0, 1.0],
    ] {
        let e = fracture_map(&p, "t", &edges, &quads, &values, "v", Some(w), &[]).unwrap_err();
        assert!(matches!(e, PlotError::Input { .. }), "{e:?}");
        assert!(e.to_string().contains("window"), "{e}");
    }
    assert_eq!(fs::read_dir(&dir).unwrap().count(), 0);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn fracture_map_degenerate_input_does_not_panic() {
    let dir = tmp_dir("fracture_map_degenerate");
    let edges = grid_edges(3, 3);
    let none: &[([f64; 2], &str)] = &[];
    fracture_map(&dir.join("a.png"), "", &[], &[], &[], "", None, none).unwrap();
    fracture_map(
        &dir.join("b.png"),
        "mesh",
        &edges,
        &[],
        &[],
        "v",
        None,
        none,
    )
    .unwrap();
    let quads = [rect(0.0, 1.0, 0.0, 0.1), rect(1.0, 2.0, 0.0, 0.1)];
    let nan = [f64::NAN; 2];
    fracture_map(
        &dir.join("c.png"),
        "nan",
        &edges,
        &quads,
        &nan,
        "v",
        None,
        none,
    )
    .unwrap();
    let odd = [
        [[f64::NAN, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
        [[2.0, 2.0]; 4],
        rect(-f64::MAX, f64::MAX, 0.0, 1e-300),
    ];
    let bad_edges = [Segment {
        a: [0.0, f64::INFINITY],
        b: [1.0, 1.0],
    }];
    let v = [1.0, 2.0, 3.0];
    let m = [([2.0, 2.0], "point")];
    fracture_map(
        &dir.join("d.png"),
        "odd",
        &bad_edges,
        &odd,
        &v,
        "v",
        None,
        &m,
    )
    .unwrap();
    let w = Some([0.0, 1e-9, 0.0, 1e-9]);
    fracture_map(
        &dir.join("e.png"),
        "tiny",
        &edges,
        &quads,
        &v[..2],
        "v",
        w,
        &m,
    )
    .unwrap();
    for f in ["a.png", "b.png", "c.png", "d.png", "e.png"] {
        assert_png(&dir.join(f));
    }
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn network_colours_and_axes() {
    // plotters' viridis, with out-of-range and non-finite input clamped.
    assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
    assert_eq!(viridis(1.0), RGBColor(254, 232, 37));
    assert_eq!(viridis(-1.0), viridis(0.0));
    assert_eq!(viridis(f64::NAN), viridis(0.0));
    assert_eq!(viridis(7.0), viridis(1.0));
    // Equal metres per pixel on both axes, same tick step.
    let (x, y) = equal_axes([0.0, 200.0, 0.0, 50.0], 800.0, 700.0, NET_PAD);
    let (mx, my) = ((x.hi - x.lo) / 800.0, (y.hi - y.lo) / 700.0);
    assert!((mx / my - 1.0).abs() < 1e-12, "{mx} {my}");
    assert_eq!(x.step, y.step);
    assert!(x.lo < 0.0 && x.hi > 200.0 && y.lo < 0.0 && y.hi > 50.0);
    // Log colour bar: exact data range, power-of-ten labels.
    let a = colour_axis(1e-9, 1e-4, ColourScale::Log);
    let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
    assert_eq!(labels, ["10⁻⁹", "10⁻⁸", "10⁻⁷", "10⁻⁶", "10⁻⁵", "10⁻⁴"]);
    assert_eq!(colour_fraction(&a, -9.0), 0.0);
    assert_eq!(colour_fraction(&a, -4.0), 1.0);
    let a = colour_axis(0.5, 20.0, ColourScale::Log);
    let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
    assert_eq!(labels, ["5×10⁻¹", "10⁰", "2×10⁰", "5×10⁰", "10¹", "2×10¹"]);
    let a = colour_axis(3.0, 3.0, ColourScale::Linear);
    assert_eq!(colour_fraction(&a, 3.0), 0.5);
}

#[test]
fn tick_labels() {
    let a = Axis::log(-3.0, 0.0);
    let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
    assert!(labels.contains(&"0.001".to_string()), "{labels:?}");
    assert!(labels.contains(&"1".to_string()), "{labels:?}");
    let a = Axis::log(-12.0, -6.0);
    let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
    assert!(labels.contains(&"10⁻⁹".to_string()), "{labels:?}");
    let a = Axis::linear(0.0, 1.0);
    let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
    assert_eq!(labels, ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
    assert_eq!(a.multiplier(), None);
    let a = Axis::linear(-1.0, 0.0);
    let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
    assert_eq!(labels.first().map(String::as_str), Some("\u{2212}1.0"));
    assert_eq!(labels.last().map(String::as_str), Some("0.0"));
    let a = Axis::linear(0.0, 3e-7);
    let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
    assert_eq!(labels, ["0.0", "0.5", "1.0", "1.5", "2.0", "2.5", "3.0"]);
    assert_eq!(a.multiplier().as_deref(), Some("×10⁻⁷"));
    // Narrow log range still gets at least two labelled ticks.
    let a = Axis::log(2f64.log10(), 4f64.log10());
    let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
    assert_eq!(labels, ["2", "3", "4"]);
}

/// Runs of inked columns (a pixel darker than 160) of what `draw` puts on a
/// white 400 x 60 px image: first column, column past the end, lowest row.
fn ink_runs(draw: impl FnOnce(&Area)) -> Vec<(usize, usize, usize)> {
    let (w, h) = (400usize, 60usize);
    let mut buf = vec![255u8; w * h * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w as u32, h as u32)).into_drawing_area();
        draw(&root);
        root.present().unwrap();
    }
    let inked = |x: usize| (0..h).filter(|&y| buf[3 * (y * w + x)] < 160).max();
    let mut runs: Vec<(usize, usize, usize)> = Vec::new();
    for x in 0..w {
        match (inked(x), runs.last_mut()) {
            (Some(b), Some(r)) if r.1 == x => (r.1, r.2) = (x + 1, r.2.max(b)),
            (Some(b), _) => runs.push((x, x + 1, b)),
            (None, _) => {}
        }
    }
    runs
}

/// Spread (largest minus smallest) of the gaps between the ink runs, and
/// the number of different lowest rows (baselines).
fn unevenness(runs: &[(usize, usize, usize)]) -> (usize, usize) {
    let gaps: Vec<usize> = runs.windows(2).map(|r| r[1].0 - r[0].1).collect();
    let spread = gaps.iter().max().unwrap() - gaps.iter().min().unwrap();
    let mut bottoms: Vec<usize> = runs.iter().map(|r| r.2).collect();
    bottoms.dedup();
    (spread, bottoms.len())
}

const EVEN_TEXT: &str = "HxHxHxH";

#[test]
fn text_spacing_and_baseline_are_even() {
    ensure_font().unwrap();
    for size in [TICK.0, DESC.0, TITLE.0] {
        let pen = Pen(size, RGBColor(0, 0, 0));
        let runs = ink_runs(|root| {
            let top_left = (HPos::Left, VPos::Top);
            pen.draw(root, EVEN_TEXT, (10, 10), top_left).unwrap();
        });
        assert_eq!(runs.len(), EVEN_TEXT.len(), "size {size}: {runs:?}");
        let (spread, baselines) = unevenness(&runs);
        assert!(spread <= 1 && baselines == 1, "size {size}: {runs:?}");
        // Anchored at the cap top (row 10): the ink ends at the baseline.
        let bottom = runs[0].2 as i32;
        assert!(
            (bottom - 10 - pen.cap()).abs() <= 1,
            "size {size}: {bottom}"
        );
        assert_eq!(pen.width(EVEN_TEXT), pen.layout(EVEN_TEXT).1.round() as i32);
    }
}

/// Why text is drawn by [`Pen`]: plotters' own text path spaces the same
/// letters unevenly (it drops the left side bearings) and puts "x" a pixel
/// above the baseline of "H" at odd sizes. Should this fail after a plotters
/// update, its text path may be good enough to replace `Pen`.
#[test]
fn plotters_text_is_uneven() {
    ensure_font().unwrap();
    let runs = |size: f32| {
        ink_runs(|root| {
            let style = ("sans-serif", size as f64).into_font().color(&BLACK);
            let style = style.pos(Pos::new(HPos::Left, VPos::Top));
            root.draw(&Text::new(EVEN_TEXT, (10, 10), style)).unwrap();
        })
    };
    let (spread, _) = unevenness(&runs(TITLE.0));
    assert!(
        spread >= 3,
        "letter gaps vary by {spread} px at {} px",
        TITLE.0
    );
    let (_, baselines) = unevenness(&runs(TICK.0));
    assert!(baselines > 1, "one baseline at {} px", TICK.0);
}

#[test]
fn legend_goes_to_the_emptiest_corner() {
    let line = |label: &str, f: fn(f64) -> f64| Series {
        label: label.into(),
        points: (0..=20).map(|i| (i as f64, f(i as f64))).collect(),
    };
    let legend_border = |p: [u8; 3]| p[0] == p[1] && p[1] == p[2] && (150..185).contains(&p[0]);
    // Rising line: the upper right corner is taken, the legend goes upper left.
    for (series, left) in [
        (line("rising", |x| x), true),
        (line("falling", |x| 20.0 - x), false),
    ] {
        let (buf, c) = render((1000, 700), |root| {
            draw_lines(root, ("t", "x", "y"), std::slice::from_ref(&series), false)
        });
        let (px, py) = plot_px(&c);
        // On the top side of a legend box inset by 12 px.
        let upper_left = pixel_of(&buf, 1000, (px.start + 20, py.start + 12));
        let upper_right = pixel_of(&buf, 1000, (px.end - 20, py.start + 12));
        assert_eq!(legend_border(upper_left), left, "{upper_left:?}");
        assert_eq!(legend_border(upper_right), !left, "{upper_right:?}");
        // The line itself is drawn in the first palette colour, with markers.
        let mid = c.translate(&(10.0, series.points[10].1));
        assert_eq!(pixel_of(&buf, 1000, mid), [31, 119, 180]);
    }
}

#[test]
fn network_pixels() {
    let seg = |y: f64| Segment {
        a: [0.0, y],
        b: [10.0, y],
    };
    let segs = [seg(0.0), seg(5.0), seg(2.5)];
    let shapes = Shapes::Lines(&segs, Some(&[6.0; 3]));
    let (values, markers) = ([1.0, 2.0, f64::NAN], [([5.0, 3.75], "pump")]);
    let linear = ColourScale::Linear;
    let (buf, c) = render((NET_WIDTH, NET_HEIGHT), |root| {
        draw_map(root, ("t", "v"), &shapes, &values, linear, &markers)
    });
    // Lowest value at the bottom of the colour bar, highest at the top.
    assert_eq!(pixel_at(&buf, &c, [2.0, 0.0]), rgb(viridis(0.0)));
    assert_eq!(pixel_at(&buf, &c, [2.0, 5.0]), rgb(viridis(1.0)));
    assert_eq!(pixel_at(&buf, &c, [2.0, 2.5]), rgb(NO_VALUE_GREY));
    assert_eq!(pixel_at(&buf, &c, [5.0, 3.75]), rgb(MARKER_FILL));
    let [r, g, b] = pixel_at(&buf, &c, [2.0, 1.25]);
    assert!(
        r == g && g == b && r > 200,
        "between the lines: {r} {g} {b}"
    );
    let (o, e) = (c.translate(&(0.0, 0.0)), c.translate(&(5.0, 5.0)));
    assert!(((e.0 - o.0) - (o.1 - e.1)).abs() <= 1, "{o:?} {e:?}");
    // The colour bar right of the plot, viridis from bottom to top.
    let (px, py) = plot_px(&c);
    let bx = px.end - 1 + BAR_GAP + BAR_W / 2;
    let (top, bot) = (py.start, py.end - 1);
    for y in [top + 1, (top + bot) / 2, bot - 1] {
        let f = (bot - y) as f64 / (bot - top) as f64;
        assert_eq!(pixel(&buf, (bx, y)), rgb(viridis(f)), "row {y}");
    }
    assert_eq!(
        pixel(&buf, (px.end + BAR_GAP / 2, top + 1)),
        [255, 255, 255]
    );
}
