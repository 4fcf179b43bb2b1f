//! 3D fracture flow (issue 38, item 5): radial diffusion in a rigid disc fracture against the
//! line-source (Theis) solution, and the coupled penny's mass balance. The cells are built
//! through the engine's own path (a disc opened on a `GradedBox`, one cell per triangle,
//! `FlowView::build_3d`), so the case checks the geometry the 3D runs use.

use super::{CaseResult, LinePlot, Row};
use crate::flow::{FlowParams, FlowView};
use crate::plot::Series;

/// The exponential integral E1(x) for x > 0: the series -gamma - ln x - sum (-x)^k / (k k!)
/// below 1, the continued fraction (modified Lentz) above; relative error near 1e-15.
pub fn e1(x: f64) -> f64 {
    const EULER: f64 = 0.577_215_664_901_532_9;
    if x < 1.0 {
        let (mut sum, mut term, mut k) = (0.0, 1.0, 1.0);
        loop {
            term *= -x / k;
            let add = term / k;
            sum += add;
            if add.abs() < 1e-17 * sum.abs().max(1e-300) {
                break;
            }
            k += 1.0;
        }
        return -EULER - x.ln() - sum;
    }
    let tiny = 1e-300;
    let mut b = x + 1.0;
    let mut c = 1.0 / tiny;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..200 {
        let an = -((i * i) as f64);
        b += 2.0;
        d = 1.0 / (an * d + b);
        c = b + an / c;
        let del = c * d;
        h *= del;
        if (del - 1.0).abs() < 1e-16 {
            break;
        }
    }
    h * (-x).exp()
}

/// A quarter disc of radius `rd` (m) at the corner of a thin graded box, rounded so that its
/// rim is a circle, with residual aperture `a` (m), full at zero pressure, and a rate boundary
/// of `q` (m^3/s) at its centre: the flow view and its parameters.
fn rigid_disc(h: f64, rd: f64, a: f64, q: f64) -> anyhow::Result<(FlowView, FlowParams)> {
    let side = 2.5 * rd;
    let text = format!(
        "(name: \"radial3d\",
          mesh: GradedBox(size: ({side}, {side}, {t}), origin: (0.0, 0.0, {z0}), h: {h},
                          fine: (0.0, 0.0, {mh}, {f}, {f}, {h}), ratio: 2.0,
                          round: Some((center: (0.0, 0.0), radius: {rd}))),
          material: (young: 20e9, poisson: 0.2, density: 2700.0),
          boundary: Sides3(left: Normal(0.0), right: Normal(0.0), front: Normal(0.0),
                           back: Normal(0.0), bottom: Normal(0.0), top: Normal(0.0)),
          fracture: Some((discs: [(center: (0.0, 0.0, 0.0), normal: (0.0, 0.0, 1.0),
                                   radius: {rd})], residual_aperture: {a})),
          initial_fluid: Full(0.0),
          flow_boundaries: [(name: \"well\", at: Node((0.0, 0.0, 0.0)), kind: Rate({q}))],
          time: (end: Time(1.0)))",
        t = 4.0 * h,
        z0 = -2.0 * h,
        mh = -h,
        f = 1.1 * rd,
    );
    let sc = crate::scenario::Scenario::parse(&text, "radial3d")?
        .validate()?
        .into_inner();
    let (model, _) = crate::sim3::build_model_3d(&sc)?;
    let fp = FlowParams::from(sc.fluid);
    let mut v = FlowView::build_3d(&model, &fp);
    v.set_bc_kinds(&sc.flow_boundaries);
    Ok((v, fp))
}

/// `hydrofrac verify radial3d`: water injected at a constant rate at the centre of a rigid,
/// uniformly open disc fracture (aperture a = 1e-4 m, a quarter of radius 4 m), explicit flow
/// sub-steps on the disc's triangles (half the stability bound) to the time at which the
/// diffusion length sqrt(4 D t) is 1.5 m. Reference: the line source in an infinite plane,
/// p(r, t) = Q / (4 pi T) E1(r^2 / (4 D t)) with T = a^3 / (12 mu), D = K a^2 / (12 mu) (the
/// disc's rim, at 4 m, changes it by about 1e-7). Error: the area-weighted L2 norm of the cell
/// pressures' deviation over the cells within 2.5 m, outside the two rings next to the well
/// (whose pressure depends on the well's connection, not on the scheme), relative to the
/// reference's norm there. Cells per disc radius 10, 20, 40 (quick: 10, 20). Mass balance
/// (the stored change against the well's injected volume, relative to the network's volume)
/// asserted to 1e-12 at every level.
pub fn radial3d(quick: bool) -> anyhow::Result<CaseResult> {
    let (rd, a, q_quarter) = (4.0, 1e-4, 1e-4);
    let hs: &[f64] = if quick { &[0.4, 0.2] } else { &[0.4, 0.2, 0.1] };
    let mut res = CaseResult::default();
    let mut csv = String::from("cells_per_radius,cells,steps,l2_error,mass_balance,wall_s\n");
    let mut pts = Vec::new();
    let mut errs = Vec::new();
    for (level, &h) in hs.iter().enumerate() {
        let t0 = std::time::Instant::now();
        let (mut v, fp) = rigid_disc(h, rd, a, q_quarter)?;
        let specs = [crate::scenario::FlowBoundary {
            name: "well".into(),
            at: crate::scenario::FlowTarget::Node(crate::scenario::Coords::three([0.0; 3])),
            kind: crate::scenario::FlowBcKind::Rate(q_quarter),
            schedule: Vec::new(),
        }];
        let d = fp.k * a * a / (12.0 * fp.mu);
        let t_end = 1.5 * 1.5 / (4.0 * d);
        let dt_crit = v.critical_step(&fp);
        let n = (t_end / (0.5 * dt_crit)).ceil() as usize;
        let dt = t_end / n as f64;
        let m0: f64 = v.stored_volume(&fp);
        for k in 0..n {
            let st = crate::systems::flow::flow_step(&mut v, &fp, &specs, dt, k as f64 * dt);
            anyhow::ensure!(st.bad_cell.is_none(), "radial3d: a cell lost its fluid");
        }
        let wall = t0.elapsed().as_secs_f64();
        for c in 0..v.n_cells() {
            v.pressure[c] = crate::flow::pressure_of(v.excess[c], v.volume[c], &fp);
        }
        let injected = v.bcs[0].volume_in;
        // Relative to the larger of the injected and the network's volume, as
        // `summary.json` `mass_balance_error` is (the cells' masses carry round-off of eps
        // times the mass they hold).
        let scale = injected.max(v.volume.iter().sum::<f64>());
        let balance = ((v.stored_volume(&fp) - m0) - injected).abs() / scale;
        res.check_max(
            format!("mass balance at h = {h} m (relative)"),
            balance,
            1e-12,
        );
        let t = a * a * a / (12.0 * fp.mu);
        let exact = |r: f64| {
            4.0 * q_quarter / (4.0 * std::f64::consts::PI * t) * e1(r * r / (4.0 * d * t_end))
        };
        let (mut num, mut den) = (0.0, 0.0);
        for c in 0..v.n_cells() {
            let x = v.centroid(c).expect("3D cell");
            let r = x[0].hypot(x[1]);
            if r > 2.5 || r < 2.0 * h {
                continue;
            }
            let pe = exact(r);
            num += v.length[c] * (v.pressure[c] - pe).powi(2);
            den += v.length[c] * pe * pe;
        }
        let err = (num / den).sqrt();
        let cpr = rd / h;
        res.rows.push(Row {
            case: "radial3d",
            level,
            h,
            unknowns: v.n_cells(),
            metric: "pressure_l2".into(),
            error: err,
            wall_s: wall,
        });
        csv.push_str(&format!(
            "{cpr},{},{n},{err:.6e},{balance:.3e},{wall:.3}\n",
            v.n_cells()
        ));
        res.notes.push(format!(
            "{cpr} cells per radius: {} cells, {n} steps, pressure L2 error {:.3} %, mass balance \
             {balance:.1e} ({wall:.2} s)",
            v.n_cells(),
            100.0 * err
        ));
        pts.push((cpr, 100.0 * err));
        errs.push(err);
    }
    // Measured (2-core VM): 8.9 / 4.5 / 2.7 % at 10 / 20 / 40 cells per radius (ratios 0.50
    // and 0.60: first order, from the bent cells and the time step). The bounds are the
    // measured errors with a margin of about a seventh; halving h must cut the error by 30 %.
    for (k, &e) in errs.iter().enumerate() {
        let bound = [0.10, 0.052, 0.031][k];
        res.check_max(
            format!("pressure L2 error at {} cells per radius", rd / hs[k]),
            e,
            bound,
        );
    }
    for w in errs.windows(2) {
        res.check_max("error ratio on halving h", w[1] / w[0], 0.7);
    }
    res.files.push(("radial3d.csv".into(), csv));
    res.plots.push(LinePlot {
        file: "radial3d.png".into(),
        title: "radial3d: injection into a rigid disc fracture against the line source".into(),
        xlabel: "cells per disc radius".into(),
        ylabel: "pressure L2 error [%]".into(),
        series: vec![Series {
            label: "explicit flow on triangles".into(),
            points: pts,
        }],
    });
    Ok(res)
}

/// A 3D scenario run to its end: the simulation and the wall time, s.
fn run(text: &str) -> anyhow::Result<(crate::sim::Simulation<crate::dim::Tet4>, f64)> {
    let t0 = std::time::Instant::now();
    let sc = crate::scenario::Scenario::parse(text, "penny_flow")?.validate()?;
    let mut sim = crate::sim::Simulation::new_3d(sc, &[])?;
    sim.run(|_| {})?;
    Ok((sim, t0.elapsed().as_secs_f64()))
}

/// `hydrofrac verify penny_flow`: `scenarios/penny_injection.ron` (water pumped into the
/// quarter penny, then the well shut) run on to rest with local damping 0.8, against the
/// static answer on the same mesh. At rest the fluid's pressure p is uniform and the rock is
/// the static penny under p: each joint opens p delta1_k, delta1_k its opening under 1 MPa from
/// the quasi-static solve of the same mesh (`fracture.pressure`, no flow), and the fluid mass
/// fills the cells, (1 + p / K) sum A_k max(p delta1_k, a_r) = V0 + V_injected (volumes at
/// the reference density). Errors: the rest pressure (area-weighted mean of the cells) against
/// that equation's root, the cells' pressure spread, the opened volume against p times the
/// static one. It checks the coupling (apertures from the joints, pressures on the faces,
/// the fluid's mass), not the mesh: both sides share the penny's discretisation error
/// (`verify penny`). R/h = 4 (quick) and 6.
pub fn penny_flow(quick: bool) -> anyhow::Result<CaseResult> {
    let base = include_str!("../../scenarios/penny_injection.ron");
    let levels: &[f64] = if quick { &[4.0] } else { &[4.0, 6.0] };
    let mut res = CaseResult::default();
    let mut csv = String::from(
        "cells_per_radius,joints,steps,rest_pressure,predicted_pressure,pressure_error,spread,volume_error,wall_s\n",
    );
    for (level, &c) in levels.iter().enumerate() {
        let h = 1.0 / c;
        let flow_text = base
            .replace("h: 0.25,", &format!("h: {h},"))
            .replace("damping: Local(0.1)", "damping: Local(0.8)")
            .replace("end: Time(0.03)", "end: Time(0.07)")
            .replace(
                "frame_every: 2000, series_every: 50",
                "frame_every: 0, series_every: 100000",
            );
        let (sim, wall) = run(&flow_text)?;
        let f = sim.flow().expect("flow");
        let fp = sim.params().fluid;
        let a_r = sim.params().residual_aperture;
        let v = &f.view;
        // The cells' area-weighted mean pressure, Pa (in 3D `length` holds each cell's area).
        let mean_pressure = |v: &crate::flow::FlowView| {
            (0..v.n_cells())
                .map(|k| v.length[k] * v.pressure[k])
                .sum::<f64>()
                / v.length.iter().sum::<f64>()
        };
        let p_rest = mean_pressure(v);
        let (pmin, pmax) = v
            .pressure
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &p| (a.min(p), b.max(p)));
        let spread = (pmax - pmin) / p_rest;
        // The fluid held, at reference density (m^3): V0 + V_injected.
        let held = v.stored_volume(&fp);
        // The static penny under 1 MPa on the same mesh.
        let static_text = flow_text
            .replace(
                "residual_aperture: 1e-4,",
                "residual_aperture: 1e-4, pressure: 1e6,",
            )
            .replace(
                "end: Time(0.07)",
                "end: Static(tol: 1e-10), solid_scheme: QuasiStatic, max_steps: 10",
            )
            .replace("damping: Local(0.8),", "");
        // Without the fluid: from `initial_fluid` to `time` out.
        let (a, b) = (
            static_text
                .find("    initial_fluid")
                .expect("initial_fluid"),
            static_text.find("    time:").expect("time"),
        );
        let static_text = format!("{}{}", &static_text[..a], &static_text[b..]);
        let (stat, _) = run(&static_text)?;
        let sv = stat.solid();
        let nj = sv.joint_nodes.len();
        let d1: Vec<f64> = (0..nj)
            .map(|k| crate::model3::joint_frame_3d(sv, k).dn / 1e6)
            .collect();
        let a0: Vec<f64> = (0..nj)
            .map(|k| crate::model3::joint_area0_3d(sv, k))
            .collect();
        let fill = |p: f64| {
            (1.0 + p / fp.k) * (0..nj).map(|k| a0[k] * (p * d1[k]).max(a_r)).sum::<f64>() - held
        };
        let (mut lo, mut hi) = (0.0, 1e9);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if fill(mid) > 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let p_pred = 0.5 * (lo + hi);
        let ep = p_rest / p_pred - 1.0;
        let sol = sim.solid();
        let opened: f64 = (0..nj)
            .map(|k| {
                crate::model3::joint_area0_3d(sol, k) * crate::model3::joint_frame_3d(sol, k).dn
            })
            .sum();
        let opened_static: f64 = (0..nj).map(|k| a0[k] * d1[k] * p_rest).sum();
        let ev = opened / opened_static - 1.0;
        res.rows.push(Row {
            case: "penny_flow",
            level,
            h,
            unknowns: 3 * sol.n_nodes() + v.n_cells(),
            metric: "rest_pressure".into(),
            error: ep.abs(),
            wall_s: wall,
        });
        csv.push_str(&format!(
            "{c},{nj},{},{p_rest:.6e},{p_pred:.6e},{ep:.4e},{spread:.3e},{ev:.4e},{wall:.2}\n",
            sim.step()
        ));
        res.notes.push(format!(
            "R/h = {c}: rest pressure {:.4} MPa against {:.4} MPa from the static compliance \
             ({:+.3} %), spread {:.1e}, opened volume {:+.3} % against p times the static one; \
             {} steps, {wall:.1} s",
            p_rest / 1e6,
            p_pred / 1e6,
            100.0 * ep,
            spread,
            100.0 * ev,
            sim.step()
        ));
        let (inj, _, _, balance) = f.balance(&fp);
        res.check_max(format!("mass balance at R/h = {c}"), balance, 1e-12);
        // 1e-3 m^3/s for 0.02 s, to within the step that straddles the switch-off (q dt).
        let slack = 1e-3 * sim.dt();
        res.check_range(
            format!("injected volume at R/h = {c} (m^3)"),
            inj,
            2e-5 - slack,
            2e-5 + slack,
        );
        // Measured 3.0e-5, 4.4e-5 and 3.3e-5 at R/h = 4, 1.5e-5, 3.1e-5 and 1.2e-5 at 6 (the
        // relaxation's residual at the end, and the fluid's load along the faces' current
        // normal against the static load's reference one): bounds of about twice those.
        res.check_max(
            format!("|rest pressure error| at R/h = {c}"),
            ep.abs(),
            1e-4,
        );
        res.check_max(format!("pressure spread at rest, R/h = {c}"), spread, 1e-4);
        res.check_max(
            format!("|opened volume error| at R/h = {c}"),
            ev.abs(),
            1e-4,
        );
        // The same with selective mass scaling x4 (`time.selective_mass_scaling`): the face
        // nodes, whose fluid springs set the step, are made heavier and the step 4 times
        // longer. The path differs (the pulse is dynamic; the heavier faces also come to rest
        // later, so the run goes on to 0.1 s); the rest state may not.
        let scaled_text = flow_text.replace(
            "end: Time(0.07)",
            "end: Time(0.1), selective_mass_scaling: Some(4.0)",
        );
        let (ss, wall_s) = run(&scaled_text)?;
        let fs = ss.flow().expect("flow");
        let p_s = mean_pressure(&fs.view);
        let es = p_s / p_pred - 1.0;
        res.rows.push(Row {
            case: "penny_flow",
            level,
            h,
            unknowns: 3 * sol.n_nodes() + v.n_cells(),
            metric: "rest_pressure_mass_scaled".into(),
            error: es.abs(),
            wall_s,
        });
        res.notes.push(format!(
            "R/h = {c}, mass scaling x4: rest pressure {:+.3} % against the static \
             compliance's; {} steps of {:.3e} s ({} without), {wall_s:.1} s",
            100.0 * es,
            ss.step(),
            ss.dt(),
            sim.step()
        ));
        res.check_max(
            format!("mass balance at R/h = {c}, mass scaling x4"),
            {
                let (_, _, _, b) = fs.balance(&fp);
                b
            },
            1e-12,
        );
        res.check_max(
            format!("|rest pressure error| at R/h = {c}, mass scaling x4"),
            es.abs(),
            1e-4,
        );
    }
    res.files.push(("penny_flow.csv".into(), csv));
    Ok(res)
}

#[cfg(test)]
mod tests {
    /// E1 against tabulated values (Abramowitz and Stegun, table 5.1): E1(0.1) =
    /// 1.822923958, E1(1) = 0.219383934, E1(2) = 0.048900511, E1(5) = 1.148295591e-3.
    #[test]
    fn exponential_integral_matches_the_tables() {
        for (x, want) in [
            (0.1, 1.822_923_958),
            (1.0, 0.219_383_934),
            (2.0, 0.048_900_511),
            (5.0, 1.148_295_591e-3),
        ] {
            let got = super::e1(x);
            assert!(
                (got / want - 1.0).abs() < 1e-8,
                "E1({x}) = {got}, want {want}"
            );
        }
    }
}
