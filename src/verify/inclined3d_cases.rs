//! `hydrofrac verify penny_inclined`: the inclined disc of `scenarios/penny_inclined.ron` in
//! the engine (a turned graded box, the disc on its faces), under pressure beside the
//! horizontal disc, and slipping under the in-situ stress without and with friction against
//! the closed form of a penny crack under a uniform stress drop.

use super::solid3d_cases::run_3d;
use super::{CaseResult, LinePlot, Row};
use crate::plot::Series;

/// Young's modulus (Pa), Poisson's ratio, the in-situ stresses (Pa, compression negative) and
/// the friction coefficient of the shipped scenario.
const YOUNG: f64 = 20e9;
const NU: f64 = 0.2;
const SIGMA_V: f64 = 30e6;
const SIGMA_H: f64 = 10e6;
const MU: f64 = 0.3;

/// The resolved stresses on the disc dipping 45 degrees: normal compression
/// (sigma_v + sigma_h) / 2 and shear (sigma_v - sigma_h) / 2, Pa.
fn resolved() -> (f64, f64) {
    (0.5 * (SIGMA_V + SIGMA_H), 0.5 * (SIGMA_V - SIGMA_H))
}

/// The potency int b dA (m^3) of a penny crack of radius 1 m under the uniform stress drop
/// `drop` (Pa): 16 (1 - nu) drop R^3 / (3 (2 - nu) G) (Eshelby; Keer).
fn potency(drop: f64) -> f64 {
    let g = YOUNG / (2.0 * (1.0 + NU));
    16.0 * (1.0 - NU) * drop / (3.0 * (2.0 - NU) * g)
}

/// `penny_inclined.ron` at `cells` per radius: the cell size and the fine box set.
fn at_level(cells: f64) -> String {
    let base = include_str!("../../scenarios/penny_inclined.ron");
    let h = 1.0 / cells;
    let f = 1.0 + h;
    let old_fine = "fine: (-1.25, -1.25, -0.25, 1.25, 1.25, 0.25)";
    assert!(base.contains(old_fine) && base.contains("h: 0.25,"));
    base.replace("h: 0.25,", &format!("h: {h},")).replace(
        old_fine,
        &format!("fine: (-{f}, -{f}, -{h}, {f}, {f}, {h})"),
    )
}

/// The disc under 1 MPa in the cube held on every side, turned (`tilt`) or horizontal.
fn pressurised(text: &str, turned: bool) -> String {
    let mut t = text
        .replace(
            "boundary: InSitu3(sxx: -10e6, syy: -10e6, szz: -30e6),",
            "boundary: Sides3(left: Fixed, right: Fixed, front: Fixed, back: Fixed, \
             bottom: Fixed, top: Fixed),",
        )
        .replace("initial_state: InSitu,", "")
        .replace(
            "normal_stiffness: 2e12,",
            "normal_stiffness: 2e12, pressure: 1e6,",
        );
    if !turned {
        t = t
            .replace("tilt: Some((1.0, 0.0, 1.0))", "tilt: None")
            .replace("normal: (1.0, 0.0, 1.0)", "normal: (0.0, 0.0, 1.0)");
    }
    t
}

/// The shipped scenario's quasi-static solve replaced by the explicit relaxation (local
/// damping 0.8) to a residual of 1e-8.
fn explicit(text: &str) -> String {
    let old = "solid_scheme: QuasiStatic, max_steps: 10";
    assert!(text.contains(old));
    text.replace(
        old,
        "solid_scheme: Explicit, max_steps: 1000000, safety: 0.9",
    )
    .replace("Static(tol: 1e-10)", "Static(tol: 1e-8)")
    .replace(
        "output: (frame_every: 1, series_every: 1,",
        "damping: Local(0.8), output: (frame_every: 0, series_every: 1000,",
    )
}

/// `hydrofrac verify penny_inclined`: R/h = 3 and 4 (quick) or 3, 4 and 6, one quasi-static
/// solve each:
/// - the disc under 1 MPa, turned and horizontal, in the cube held on every side: opened volume
///   against Sneddon's 16 p R^3 / (3 E'), and the two against each other (the turned grid is
///   the horizontal one rotated: the same to round-off);
/// - the disc slipping under the in-situ stress, frictionless (stress drop tau = 10 MPa) and
///   with mu = 0.3 (drop tau - mu sigma_n = 4 MPa): the potency against the closed form, the
///   ratio of the two potencies against the drops' ratio 0.4 (the mesh's error cancels: what
///   is left is the friction's), and the slip's direction against the resolved shear's;
/// - at R/h = 3 (and 4 in full), the frictional slip relaxed by the explicit scheme beside the
///   quasi-static solve: the potencies the same to the relaxation's tolerance.
pub fn penny_inclined(quick: bool) -> anyhow::Result<CaseResult> {
    let levels: &[f64] = if quick { &[3.0, 4.0] } else { &[3.0, 4.0, 6.0] };
    let (sigma_n, tau) = resolved();
    let want_v = 16.0 * 1e6 * (1.0 - NU * NU) / (3.0 * YOUNG);
    let down_dip = [1.0 / 2f64.sqrt(), 0.0, -1.0 / 2f64.sqrt()];
    let mut res = CaseResult::default();
    let mut csv = String::from(
        "cells_per_radius,tetrahedra,volume_error_turned,volume_error_horizontal,\
         turned_vs_horizontal,potency_error_frictionless,potency_error_friction,\
         friction_ratio_error,slip_angle_deg,explicit_vs_quasi_static,explicit_wall_s,wall_s\n",
    );
    let mut pts: [Vec<(f64, f64)>; 3] = Default::default();
    let mut last: Option<[f64; 2]> = None;
    for (level, &c) in levels.iter().enumerate() {
        let text = at_level(c);
        let t0 = std::time::Instant::now();
        let (turned, _) = run_3d(&pressurised(&text, true))?;
        let (flat, _) = run_3d(&pressurised(&text, false))?;
        let v_turned = crate::model3::opening_3d(turned.solid()).volume;
        let v_flat = crate::model3::opening_3d(flat.solid()).volume;
        let (ev_t, ev_f) = (v_turned / want_v - 1.0, v_flat / want_v - 1.0);
        let same = (v_turned / v_flat - 1.0).abs();
        let (slip, _) = run_3d(&text)?;
        let free_text = text.replace("friction_deg: 16.69924423399362,", "friction_deg: 0.0,");
        let (free, _) = run_3d(&free_text)?;
        let wall = t0.elapsed().as_secs_f64();
        let o_mu = crate::model3::opening_3d(slip.solid());
        // The explicit relaxation beside it (R/h = 3; and 4 in full).
        let (schemes_apart, wall_ex) = if c <= 3.0 || (!quick && c <= 4.0) {
            let (ex, w) = run_3d(&explicit(&text))?;
            let p = crate::model3::opening_3d(ex.solid()).potency;
            let apart = (p / o_mu.potency - 1.0).abs();
            res.rows.push(Row {
                case: "penny_inclined",
                level,
                h: 1.0 / c,
                unknowns: 3 * ex.solid().n_nodes(),
                metric: "potency_friction_explicit".into(),
                error: (p / potency(tau - MU * sigma_n) - 1.0).abs(),
                wall_s: w,
            });
            // Measured 3.6e-6 at R/h = 3: the relaxation stops at a residual of 1e-8.
            res.check_max(
                format!("explicit against quasi-static potency at R/h = {c}"),
                apart,
                1e-4,
            );
            (apart, w)
        } else {
            (f64::NAN, f64::NAN)
        };
        let o_free = crate::model3::opening_3d(free.solid());
        let e_free = o_free.potency / potency(tau) - 1.0;
        let e_mu = o_mu.potency / potency(tau - MU * sigma_n) - 1.0;
        let ratio = o_mu.potency / o_free.potency / ((tau - MU * sigma_n) / tau) - 1.0;
        let s = o_mu.slip_vector;
        let cos = (s[0] * down_dip[0] + s[1] * down_dip[1] + s[2] * down_dip[2])
            / (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        let angle = cos.clamp(-1.0, 1.0).acos().to_degrees();
        let tets = slip.solid().n_elems();
        let unknowns = 3 * slip.solid().n_nodes();
        for (m, err) in [
            ("volume_turned", ev_t),
            ("volume_horizontal", ev_f),
            ("potency_frictionless", e_free),
            ("potency_friction", e_mu),
            ("friction_ratio", ratio),
        ] {
            res.rows.push(Row {
                case: "penny_inclined",
                level,
                h: 1.0 / c,
                unknowns,
                metric: m.into(),
                error: err.abs(),
                wall_s: wall,
            });
        }
        csv.push_str(&format!(
            "{c},{tets},{ev_t:.6e},{ev_f:.6e},{same:.3e},{e_free:.6e},{e_mu:.6e},{ratio:.4e},\
             {angle:.4},{},{},{wall:.2}\n",
            if schemes_apart.is_nan() {
                String::new()
            } else {
                format!("{schemes_apart:.3e}")
            },
            if wall_ex.is_nan() {
                String::new()
            } else {
                format!("{wall_ex:.2}")
            },
        ));
        res.notes.push(format!(
            "R/h = {c} ({tets} tetrahedra, {wall:.1} s for the four solves): volume {:+.2} % \
             turned, {:+.2} % horizontal (apart by {same:.1e}); potency {:+.2} % frictionless, \
             {:+.2} % with friction; friction's ratio {:+.2} %; slip {angle:.2} degrees off \
             down-dip",
            100.0 * ev_t,
            100.0 * ev_f,
            100.0 * e_free,
            100.0 * e_mu,
            100.0 * ratio
        ));
        pts[0].push((c, 100.0 * ev_t.abs()));
        pts[1].push((c, 100.0 * e_free.abs()));
        pts[2].push((c, 100.0 * e_mu.abs()));
        // The turned grid is the horizontal one rotated: 2e-15 measured.
        res.check_max(
            format!("turned against horizontal at R/h = {c}"),
            same,
            1e-9,
        );
        // Measured at R/h = 3 / 4: friction's ratio +1.5 / +1.1 %, slip 0.1 degrees off.
        res.check_max(
            format!("|friction ratio error| at R/h = {c}"),
            ratio.abs(),
            0.03,
        );
        res.check_max(format!("slip angle at R/h = {c} (degrees)"), angle, 1.0);
        // First order in h, like the opening: -43 / -34 % at R/h = 3 / 4 measured.
        let bound = 1.6 / c;
        res.check_max(
            format!("|potency error| at R/h = {c}, frictionless"),
            e_free.abs(),
            bound,
        );
        res.check_max(
            format!("|potency error| at R/h = {c}, friction"),
            e_mu.abs(),
            bound,
        );
        if let Some([a, b]) = last {
            res.check_max(
                format!("potency error shrinks to R/h = {c}, frictionless"),
                e_free.abs() / a,
                0.95,
            );
            res.check_max(
                format!("potency error shrinks to R/h = {c}, friction"),
                e_mu.abs() / b,
                0.95,
            );
        }
        last = Some([e_free.abs(), e_mu.abs()]);
    }
    res.files.push(("penny_inclined.csv".into(), csv));
    res.plots.push(LinePlot {
        file: "penny_inclined.png".into(),
        title: "inclined penny: opened volume (1 MPa) and slip potency against the closed forms"
            .into(),
        xlabel: "cells per radius R/h".into(),
        ylabel: "|error| [%]".into(),
        series: vec![
            Series {
                label: "opened volume (turned)".into(),
                points: pts[0].clone(),
            },
            Series {
                label: "potency, frictionless".into(),
                points: pts[1].clone(),
            },
            Series {
                label: "potency, mu = 0.3".into(),
                points: pts[2].clone(),
            },
        ],
    });
    Ok(res)
}
