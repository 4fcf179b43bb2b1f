//! Figures written at the end of a run (PNG): the network coloured by pressure and by flow rate,
//! and the boundary pressures and rates against time.

use crate::flow::FlowView;
use crate::output::folder::Folder;
use crate::params::RunParams;
use crate::plot::{ColourScale, Segment, Series, fracture_map, lines, network};
use crate::view::SolidView;
use std::path::Path;

/// `network_pressure.png`, `network_flow.png` and `boundaries.png` for a scene with a network.
pub fn flow_figures(v: &FlowView, p: &RunParams, time: f64, dir: &Folder) -> anyhow::Result<()> {
    if v.corners.is_empty() {
        network_figures(v, p, time, dir)?;
    } else {
        surface_figures(v, p, time, dir)?;
    }
    boundary_figures(v, p, dir)
}

/// Map cells as quadrilaterals in the plane of a figure, m.
type Quads = Vec<[[f64; 2]; 4]>;

/// 3D fracture triangles seen along their area-weighted mean normal (each triangle's normal
/// turned to one side first; for one planar disc, the disc itself): each triangle as a
/// degenerate quadrilateral in the view's plane, and the map from a point to that plane.
fn surface_view(corners: &[[[f64; 3]; 3]]) -> (Quads, impl Fn([f64; 3]) -> [f64; 2]) {
    use crate::tet4::{cross, dot, norm, sub};
    let mut n = [0.0; 3];
    for c in corners {
        let mut m = cross(sub(c[1], c[0]), sub(c[2], c[0]));
        let big = (0..3)
            .max_by(|&a, &b| m[a].abs().total_cmp(&m[b].abs()))
            .unwrap_or(2);
        if m[big] < 0.0 {
            m = m.map(|x| -x);
        }
        (0..3).for_each(|d| n[d] += m[d]);
    }
    let nn = norm(n);
    let n = if nn > 0.0 {
        n.map(|x| x / nn)
    } else {
        [0.0, 0.0, 1.0]
    };
    // In-plane axes: the world axis least along n, made orthogonal to it, and n x e1.
    let k = (0..3)
        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
        .unwrap_or(0);
    let mut e1 = [0.0; 3];
    e1[k] = 1.0;
    let e1 = sub(e1, n.map(|x| x * n[k]));
    let e1 = e1.map(|x| x / norm(e1));
    let e2 = cross(n, e1);
    let to2 = move |x: [f64; 3]| [dot(x, e1), dot(x, e2)];
    let quads = corners
        .iter()
        .map(|c| [to2(c[0]), to2(c[1]), to2(c[2]), to2(c[2])])
        .collect();
    (quads, to2)
}

/// 3D: `fracture_aperture.png` and `fracture_pressure.png`, the fracture triangles seen along
/// their mean normal ([`surface_view`]), coloured by the hydraulic aperture (mm) and the fluid
/// pressure (MPa), boundaries marked.
fn surface_figures(v: &FlowView, p: &RunParams, time: f64, dir: &Folder) -> anyhow::Result<()> {
    let (quads, to2) = surface_view(&v.corners);
    let markers = boundary_markers(v, p, |at| {
        to2([at[0], at[1], at.get(2).copied().unwrap_or(0.0)])
    });
    let mm: Vec<f64> = v.aperture.iter().map(|a| a * 1e3).collect();
    let mpa: Vec<f64> = v.pressure.iter().map(|p| p / 1e6).collect();
    let t = time;
    for (file, what, values, label) in [
        (
            "fracture_aperture.png",
            "hydraulic aperture",
            &mm,
            "aperture [mm]",
        ),
        (
            "fracture_pressure.png",
            "fluid pressure",
            &mpa,
            "pressure [MPa]",
        ),
    ] {
        fracture_map(
            &dir.claim(file)?,
            &format!("{}: {what} at t = {t:.4e} s", p.name),
            &[],
            &quads,
            values,
            label,
            None,
            &markers,
        )?;
    }
    Ok(())
}

/// 3D runs with joints: `fracture_opening.png` and `fracture_slip.png`, the fracture triangles
/// (face p of each joint, in the reference positions) seen along their mean normal
/// ([`surface_view`]), coloured by the opening delta_n and the slip |delta_t| (mm) at the end.
pub fn joint_figures(
    v: &SolidView<crate::dim::Tet4>,
    name: &str,
    time: f64,
    dir: &Folder,
) -> anyhow::Result<()> {
    if v.joint_nodes.is_empty() {
        return Ok(());
    }
    let corners: Vec<[[f64; 3]; 3]> = v
        .joint_nodes
        .iter()
        .map(|j| [0, 1, 2].map(|a| v.x0[j[a] as usize]))
        .collect();
    let (quads, _) = surface_view(&corners);
    let frames: Vec<_> = (0..v.joint_nodes.len())
        .map(|k| crate::model3::joint_frame_3d(v, k))
        .collect();
    let opening: Vec<f64> = frames.iter().map(|f| f.dn * 1e3).collect();
    let slip: Vec<f64> = frames
        .iter()
        .map(|f| f.dt[0].hypot(f.dt[1]) * 1e3)
        .collect();
    for (file, what, values, label) in [
        ("fracture_opening.png", "opening", &opening, "opening [mm]"),
        ("fracture_slip.png", "slip", &slip, "slip [mm]"),
    ] {
        fracture_map(
            &dir.claim(file)?,
            &format!("{name}: {what} at t = {time:.4e} s"),
            &[],
            &quads,
            values,
            label,
            None,
            &[],
        )?;
    }
    Ok(())
}

/// Each flow boundary's point, placed on the map by `place`, with its name.
fn boundary_markers<'a>(
    v: &FlowView,
    p: &'a RunParams,
    place: impl Fn(&[f64]) -> [f64; 2],
) -> Vec<([f64; 2], &'a str)> {
    v.bcs
        .iter()
        .map(|b| {
            let at = p.flow_boundaries[b.index].at.point();
            (place(at), p.bc_names[b.index].as_str())
        })
        .collect()
}

/// `boundary_pressure.png` and `boundary_rate.png`: each boundary's pressure and rate against
/// time, from the time series.
fn boundary_figures(v: &FlowView, p: &RunParams, dir: &Folder) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(dir.dir.join("timeseries.csv"))?;
    let mut rows = text.lines();
    let header: Vec<&str> = rows.next().unwrap_or("").split(',').collect();
    let data: Vec<Vec<f64>> = rows
        .map(|l| {
            l.split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let t = col("time").unwrap_or(1);
    let mut pressure = Vec::new();
    let mut rate = Vec::new();
    for b in &v.bcs {
        let name = p.bc_names[b.index].clone();
        if let Some(c) = col(&format!("{name}_pressure")) {
            pressure.push(Series {
                label: name.clone(),
                points: data.iter().map(|r| (r[t], r[c] / 1e6)).collect(),
            });
        }
        if let Some(c) = col(&format!("{name}_rate")) {
            rate.push(Series {
                label: name,
                points: data.iter().map(|r| (r[t], r[c])).collect(),
            });
        }
    }
    if !pressure.is_empty() {
        lines(
            &dir.claim("boundary_pressure.png")?,
            "Boundary pressure",
            "time [s]",
            "pressure [MPa]",
            &pressure,
        )?;
        lines(
            &dir.claim("boundary_rate.png")?,
            "Boundary rate into the network",
            "time [s]",
            if v.corners.is_empty() {
                "rate [m^2/s]"
            } else {
                "rate [m^3/s]"
            },
            &rate,
        )?;
    }
    Ok(())
}

/// The network coloured by pressure (linear, MPa) and by flow rate (log, m^2/s), line width
/// growing with aperture, boundaries marked.
fn network_figures(v: &FlowView, p: &RunParams, time: f64, dir: &Folder) -> anyhow::Result<()> {
    let segments: Vec<Segment> = v
        .cell_nodes
        .iter()
        .map(|n| Segment {
            a: v.node_pos[n[0] as usize],
            b: v.node_pos[n[1] as usize],
        })
        .collect();
    // Width 1.5 to 6 px, growing with log aperture across the network's range.
    let (amin, amax) = v
        .aperture
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), &a| {
            (lo.min(a), hi.max(a))
        });
    let widths: Vec<f64> = v
        .aperture
        .iter()
        .map(|&a| {
            let s = if amax > amin {
                (a / amin).ln() / (amax / amin).ln()
            } else {
                0.5
            };
            1.5 + 4.5 * s
        })
        .collect();
    let markers = boundary_markers(v, p, |at| [at[0], at[1]]);
    let mpa: Vec<f64> = v.pressure.iter().map(|p| p / 1e6).collect();
    let t = time;
    network(
        &dir.claim("network_pressure.png")?,
        &format!("{}: fluid pressure at t = {t:.4e} s", p.name),
        &segments,
        &mpa,
        "pressure [MPa]",
        ColourScale::Linear,
        Some(&widths),
        &markers,
    )?;
    network(
        &dir.claim("network_flow.png")?,
        &format!("{}: flow rate at t = {t:.4e} s", p.name),
        &segments,
        &v.flow_rate,
        "flow rate [m^2/s]",
        ColourScale::Log,
        Some(&widths),
        &markers,
    )?;
    Ok(())
}

/// `fractures.png` for a rock scene with fractures: the fracture cells drawn with line width
/// growing with the hydraulic aperture and coloured by it (mm), like the seed's Fig. 7 (which
/// magnifies apertures 20x in the mesh instead).
pub fn fracture_figure(name: &str, time: f64, view: &FlowView, dir: &Folder) -> anyhow::Result<()> {
    let segments: Vec<Segment> = view
        .cell_nodes
        .iter()
        .map(|n| Segment {
            a: view.node_pos[n[0] as usize],
            b: view.node_pos[n[1] as usize],
        })
        .collect();
    let amax = view.aperture.iter().fold(0.0f64, |a, &b| a.max(b));
    let widths: Vec<f64> = view
        .aperture
        .iter()
        .map(|&a| 1.5 + 6.0 * a / amax.max(1e-300))
        .collect();
    let mm: Vec<f64> = view.aperture.iter().map(|a| a * 1e3).collect();
    network(
        &dir.claim("fractures.png")?,
        &format!("{name}: fracture apertures at t = {time:.4e} s"),
        &segments,
        &mm,
        "hydraulic aperture [mm]",
        ColourScale::Linear,
        Some(&widths),
        &[],
    )?;
    Ok(())
}

/// A figure like the seed's Fig. 7: the rock mesh in its current configuration (x0 + u) as thin
/// grey lines, and every fracture cell of `flow` drawn as a quad centred on its segment (the
/// cell's two nodes at `flow.node_pos`, the fracture's mid-surface as of the flow view's last
/// rebuild), `magnify` times as wide as its hydraulic aperture (e.g. 20), filled with the
/// colour of its fluid pressure (MPa); PNG at `path` (see [`fracture_map`]).
///
/// `window` (`[xmin, xmax, ymin, ymax]`, m) is the region shown; by default the bounding box of
/// the cells plus a margin of 20 % of its larger side (at least [`MIN_WINDOW_MARGIN`]) on each
/// side, cut to the mesh's bounding box (the whole mesh when there are no cells). Errors: a
/// `magnify` that is not finite and non-negative, and those of [`fracture_map`].
pub fn fracture_pressure_figure(
    path: &Path,
    title: &str,
    solid: &SolidView,
    flow: &FlowView,
    magnify: f64,
    window: Option<[f64; 4]>,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        magnify.is_finite() && magnify >= 0.0,
        "aperture magnification {magnify} is not a finite, non-negative number"
    );
    let edges = mesh_edges(solid);
    let quads = cell_quads(flow, magnify);
    let mpa: Vec<f64> = flow.pressure.iter().map(|p| p / 1e6).collect();
    let window = window.or_else(|| fracture_window(flow, &edges));
    let label = "fluid pressure [MPa]";
    fracture_map(path, title, &edges, &quads, &mpa, label, window, &[])?;
    Ok(())
}

/// Smallest margin of [`fracture_pressure_figure`]'s default window, m.
pub const MIN_WINDOW_MARGIN: f64 = 3.0;

/// The edges of the solid's elements in the current configuration (x0 + u, m), each once.
pub fn mesh_edges(solid: &SolidView) -> Vec<Segment> {
    let mut pairs: Vec<[u32; 2]> = Vec::with_capacity(3 * solid.conn.len());
    for c in &solid.conn {
        for k in 0..3 {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            pairs.push([a.min(b), a.max(b)]);
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    pairs
        .iter()
        .map(|&[a, b]| Segment {
            a: solid.position(a as usize),
            b: solid.position(b as usize),
        })
        .collect()
}

/// One quad per flow cell, m: from a = `node_pos` of its first node to b of its second, half
/// `magnify` times its aperture wide on each side, corners [a - h n, b - h n, b + h n, a + h n]
/// with n the unit normal (-t_y, t_x) of the unit tangent t = (b - a)/|b - a| and h = magnify a / 2
/// (a cell of zero length gives a point).
pub fn cell_quads(flow: &FlowView, magnify: f64) -> Vec<[[f64; 2]; 4]> {
    flow.cell_nodes
        .iter()
        .zip(&flow.aperture)
        .map(|(nodes, &aperture)| {
            let [a, b] = nodes.map(|n| flow.node_pos[n as usize]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len = dx.hypot(dy);
            let h = 0.5 * magnify * aperture;
            let [nx, ny] = if len > 0.0 {
                [-dy / len * h, dx / len * h]
            } else {
                [0.0, 0.0]
            };
            [
                [a[0] - nx, a[1] - ny],
                [b[0] - nx, b[1] - ny],
                [b[0] + nx, b[1] + ny],
                [a[0] + nx, a[1] + ny],
            ]
        })
        .collect()
}

/// Default window of [`fracture_pressure_figure`], `[xmin, xmax, ymin, ymax]` (m): the box of
/// the cells' finite end points plus max(20 % of its larger side, [`MIN_WINDOW_MARGIN`]) on
/// each side, cut to the box of `edges` where that leaves a non-empty region; the box of
/// `edges` without cells; `None` without either.
fn fracture_window(flow: &FlowView, edges: &[Segment]) -> Option<[f64; 4]> {
    fn bbox(points: impl Iterator<Item = [f64; 2]>) -> Option<[f64; 4]> {
        points
            .filter(|p| p[0].is_finite() && p[1].is_finite())
            .fold(None, |b, [x, y]| {
                let [x0, x1, y0, y1] = b.unwrap_or([x, x, y, y]);
                Some([x0.min(x), x1.max(x), y0.min(y), y1.max(y)])
            })
    }
    let mesh = bbox(edges.iter().flat_map(|s| [s.a, s.b]));
    let ends = flow.cell_nodes.iter().flatten();
    let Some([x0, x1, y0, y1]) = bbox(ends.map(|&n| flow.node_pos[n as usize])) else {
        return mesh.filter(|[x0, x1, y0, y1]| x0 < x1 && y0 < y1);
    };
    let m = (0.2 * (x1 - x0).max(y1 - y0)).max(MIN_WINDOW_MARGIN);
    let w = [x0 - m, x1 + m, y0 - m, y1 + m];
    let cut = mesh.map(|b| {
        [
            w[0].max(b[0]),
            w[1].min(b[1]),
            w[2].max(b[2]),
            w[3].min(b[3]),
        ]
    });
    Some(match cut {
        Some(c) if c[0] < c[1] && c[2] < c[3] => c,
        _ => w,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4 x 2 grid of 1 m squares, two triangles each, displaced by `u` = (0.01 x, 0) m.
    fn solid() -> SolidView {
        let mut v = SolidView::default();
        for j in 0..=2 {
            for i in 0..=4 {
                v.x0.push([i as f64, j as f64]);
                v.u.push([0.01 * i as f64, 0.0]);
            }
        }
        for j in 0..2u32 {
            for i in 0..4u32 {
                let n = |i: u32, j: u32| j * 5 + i;
                v.conn.push([n(i, j), n(i + 1, j), n(i + 1, j + 1)]);
                v.conn.push([n(i, j), n(i + 1, j + 1), n(i, j + 1)]);
            }
        }
        v
    }

    /// Two cells along y = 1 from x = 1 to 3, apertures 1 mm and 2 mm, and a vertical one.
    fn flow() -> FlowView {
        FlowView {
            node_pos: vec![[1.0, 1.0], [2.0, 1.0], [3.0, 1.0], [2.0, 2.0]],
            cell_nodes: vec![[0, 1], [1, 2], [1, 3]],
            aperture: vec![1e-3, 2e-3, 5e-4],
            pressure: vec![12e6, 8e6, 1e6],
            ..Default::default()
        }
    }

    #[test]
    fn mesh_edges_once_each_in_current_positions() {
        let s = solid();
        let e = mesh_edges(&s);
        // 4 x 3 horizontal, 5 x 2 vertical, 8 diagonal edges.
        assert_eq!(e.len(), 12 + 10 + 8);
        let top_right = Segment {
            a: [3.03, 2.0],
            b: [4.04, 2.0],
        };
        assert!(e.contains(&top_right), "{e:?}");
    }

    #[test]
    fn cell_quads_are_magnified_apertures_about_the_cells() {
        let q = cell_quads(&flow(), 20.0);
        assert_eq!(q.len(), 3);
        // Horizontal cell, 1 mm x 20 = 2 cm wide, centred on y = 1.
        let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-12;
        let want = [[1.0, 0.99], [2.0, 0.99], [2.0, 1.01], [1.0, 1.01]];
        for (c, w) in q[0].iter().zip(want) {
            assert!(close(*c, w), "{:?}", q[0]);
        }
        assert!(close(q[1][0], [2.0, 0.98]), "{:?}", q[1]);
        // Vertical cell: normal along -x.
        let want = [[2.005, 1.0], [2.005, 2.0], [1.995, 2.0], [1.995, 1.0]];
        for (c, w) in q[2].iter().zip(want) {
            assert!(close(*c, w), "{:?}", q[2]);
        }
    }

    #[test]
    fn default_window_margin_and_cut() {
        let s = solid();
        let edges = mesh_edges(&s);
        // Cells' box [1, 3] x [1, 2]: margin 3 m, cut to the mesh [0, 4.04] x [0, 2].
        let w = fracture_window(&flow(), &edges).unwrap();
        assert_eq!(w, [0.0, 4.04, 0.0, 2.0]);
        // A long fracture: 20 % of its length.
        let mut f = flow();
        f.node_pos[2] = [41.0, 1.0];
        let w = fracture_window(&f, &[]).unwrap();
        let want = [1.0 - 8.0, 41.0 + 8.0, 1.0 - 8.0, 2.0 + 8.0];
        assert!(
            w.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12),
            "{w:?}"
        );
        // No cells: the mesh.
        let w = fracture_window(&FlowView::default(), &edges).unwrap();
        assert_eq!(w, [0.0, 4.04, 0.0, 2.0]);
        assert_eq!(fracture_window(&FlowView::default(), &[]), None);
    }

    /// Seed Example I sized case (100 m x 100 m, h = 1 m: 20,000 elements): a horizontal
    /// fracture from the pump at (0, 50) m to x = 30 m crossing a vertical one at x = 16 m.
    /// Written to `$PLOT_EXAMPLES_DIR` when set (kept), else to a temporary folder (removed).
    #[test]
    fn fig7_example_renders() {
        let mut s = SolidView::default();
        let n = 100u32;
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f64, j as f64);
                s.x0.push([x, y]);
                // Faces pushed apart around y = 50 m for x < 30 m.
                let open = if x < 30.0 {
                    2e-3 * (1.0 - x / 30.0)
                } else {
                    0.0
                };
                s.u.push([
                    0.0,
                    (y - 50.0).signum() * open * (-(y - 50.0).abs() / 5.0).exp(),
                ]);
            }
        }
        let id = |i: u32, j: u32| j * (n + 1) + i;
        for j in 0..n {
            for i in 0..n {
                s.conn.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                s.conn.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        assert_eq!(s.conn.len(), 20_000);
        let mut f = FlowView::default();
        for i in 0..=30 {
            f.node_pos.push([i as f64, 50.0]);
        }
        for i in 0..30u32 {
            let x = i as f64 + 0.5;
            f.cell_nodes.push([i, i + 1]);
            f.aperture.push(5e-4 + 4e-3 * (1.0 - x / 30.0).sqrt());
            f.pressure.push(18e6 - 8e6 * x / 30.0);
        }
        for j in 46..=54 {
            if j != 50 {
                f.node_pos.push([16.0, j as f64]);
            }
        }
        let k = |j: u32| {
            if j == 50 {
                16
            } else {
                31 + j - 46 - u32::from(j > 50)
            }
        };
        for j in 46..54u32 {
            f.cell_nodes.push([k(j), k(j + 1)]);
            f.aperture.push(5e-4);
            f.pressure.push(12e6 - 1e6 * (j as f64 + 0.5 - 50.0).abs());
        }
        let keep = std::env::var_os("PLOT_EXAMPLES_DIR").map(std::path::PathBuf::from);
        let dir = keep.clone().unwrap_or_else(|| {
            std::env::temp_dir().join(format!("fig7_example_{}", std::process::id()))
        });
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("fig7_example.png");
        let title = "Example I: fluid pressure, apertures x20";
        let t = std::time::Instant::now();
        fracture_pressure_figure(&p, title, &s, &f, 20.0, None).unwrap();
        eprintln!("fig7 example: {:.3} s", t.elapsed().as_secs_f64());
        let w = Some([0.0, 100.0, 0.0, 100.0]);
        let whole = dir.join("fig7_example_whole.png");
        fracture_pressure_figure(&whole, title, &s, &f, 20.0, w).unwrap();
        let w = Some([13.0, 19.0, 48.5, 51.5]);
        let zoom = dir.join("fig7_example_zoom.png");
        fracture_pressure_figure(&zoom, title, &s, &f, 20.0, w).unwrap();
        assert!(std::fs::metadata(&p).unwrap().len() > 5000);
        if keep.is_none() {
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }

    #[test]
    fn fracture_pressure_figure_writes_png() {
        let dir = std::env::temp_dir().join(format!("fig7_test_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("fig7.png");
        fracture_pressure_figure(&p, "Fig. 7", &solid(), &flow(), 20.0, None).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        let e = fracture_pressure_figure(&p, "", &solid(), &flow(), f64::NAN, None).unwrap_err();
        assert!(e.to_string().contains("magnification"), "{e}");
        let w = Some([1.0, 0.0, 0.0, 1.0]);
        assert!(fracture_pressure_figure(&p, "", &solid(), &flow(), 20.0, w).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
