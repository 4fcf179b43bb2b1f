//! The seed's Example I (`docs/verification.md` R9) with both solid schemes side by side:
//! `scenarios/example1_cross.ron` (friction 45 deg) and `example1_offset.ron` (3 deg), each run
//! with the explicit rock (the seed's scheme, the reference) and the quasi-static rock, 1.5 s
//! simulated, also with `--quick` (the quasi-static offset run shortened to 0.6 s stalls at
//! 0.362 s: README, "Choosing the solid scheme"). A run that fails is a failed check with its
//! reason, not an abort of `verify`.
//!
//! There is no closed form: the checks are the seed's Fig. 7 outcome for each scheme (cross:
//! the fracture continues past x = 17 m at y = 50 m and the vertical fracture stays mostly at
//! its residual aperture; offset: nothing starts on the far side at y = 50 m, fluid fills the
//! vertical fracture and new fractures start near its tips) and the agreement of the schemes:
//! every cell the explicit run opens, the quasi-static run opens too, on the same paths (its
//! extra cells are the continuation of a path: the quasi-static rock has no inertia, so each
//! face reaches the criterion somewhat earlier); creation times and injected volume within
//! stated bounds of each other. Mass balance 1e-9 in every run.
//!
//! Rows: for each scheme, the difference to the other scheme (relative to the explicit run's
//! value) of the injected volume (`<case>_injected_<scheme>`) and of the mean creation time of
//! the cells both open (`<case>_created_<scheme>`), with that scheme's wall time, so the plot
//! shows the same answer at two costs. `example1_cells.csv` lists each opened cell with its
//! creation time in both schemes (an empty field: that scheme did not open it).

use super::{CaseResult, Row};
use crate::flow::FlowView;
use crate::scenario::Scenario;
use crate::sim::{Finish, Simulation};
use std::time::Instant;

const CROSS_RON: &str = include_str!("../../scenarios/example1_cross.ron");
const OFFSET_RON: &str = include_str!("../../scenarios/example1_offset.ron");

/// A cell of the network in reference geometry: x range, y range (m), hydraulic aperture (m),
/// pressure (Pa), creation time (s; 0 for the pre-existing cells).
#[derive(Clone, Copy, Debug)]
pub struct CellRow {
    pub x: [f64; 2],
    pub y: [f64; 2],
    pub aperture: f64,
    pub pressure: f64,
    pub created: f64,
}

impl CellRow {
    /// On the pre-existing vertical fracture x = 16 m.
    pub fn vertical(&self) -> bool {
        (self.x[0] - 16.0).abs() < 1e-6 && (self.x[1] - 16.0).abs() < 1e-6
    }
    /// Same cell (same reference end points, to 1 mm).
    fn same(&self, o: &CellRow) -> bool {
        (0..2).all(|k| (self.x[k] - o.x[k]).abs() < 1e-3 && (self.y[k] - o.y[k]).abs() < 1e-3)
    }
}

/// Every cell of a network, reference geometry.
pub fn cells(v: &FlowView) -> Vec<CellRow> {
    (0..v.n_cells())
        .map(|c| {
            let [a, b] = v.cell_nodes[c].map(|n| v.node_ref[n as usize]);
            CellRow {
                x: [a[0].min(b[0]), a[0].max(b[0])],
                y: [a[1].min(b[1]), a[1].max(b[1])],
                aperture: v.aperture[c],
                pressure: v.pressure[c],
                created: v.created_t[c],
            }
        })
        .collect()
}

/// One Example I run: its cells, injected volume (m^2 per metre), mass-balance error, steps,
/// wall time (s) and unknowns.
pub struct ExampleRun {
    pub cells: Vec<CellRow>,
    pub injected: f64,
    pub balance: f64,
    pub steps: u64,
    pub wall: f64,
    pub unknowns: usize,
}

impl ExampleRun {
    /// The cells the run created (not pre-existing).
    pub fn new_cells(&self) -> Vec<CellRow> {
        self.cells
            .iter()
            .filter(|c| c.created > 0.0)
            .copied()
            .collect()
    }
}

/// Run an Example I scenario text `ron` (named `file` in errors) to `end` s with `sets`.
pub fn example_run(ron: &str, file: &str, end: f64, sets: &[String]) -> anyhow::Result<ExampleRun> {
    let mut all = vec![format!("time.end=Time({end})")];
    all.extend_from_slice(sets);
    let sc = Scenario::parse(ron, file)?.with_overrides(&all)?;
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    let finish = sim.run(|_| {})?;
    anyhow::ensure!(finish == Finish::EndTime, "{file}: ended with {finish:?}");
    let wall = t0.elapsed().as_secs_f64();
    let (injected, _, _, balance) = sim.flow_balance().expect("Example I has flow");
    Ok(ExampleRun {
        cells: cells(&sim.flow().expect("flow").view),
        injected,
        balance,
        steps: sim.clock().step,
        wall,
        unknowns: 2 * sim.solid().n_nodes(),
    })
}

/// The seed's Fig. 7 outcome of a crossing run: (new cells past x = 17 m on y = 50 m,
/// vertical cells at the residual aperture of 8, new cells off the y = 50 m line near x >= 15).
pub fn cross_outcome(r: &ExampleRun) -> (usize, usize, usize) {
    let new = r.new_cells();
    let beyond = new
        .iter()
        .filter(|c| c.x[0] >= 17.0 - 1e-6 && (c.y[0] - 50.0).abs() < 0.5)
        .count();
    let closed = r
        .cells
        .iter()
        .filter(|c| c.vertical() && c.aperture <= 5e-4 * (1.0 + 1e-9))
        .count();
    let off_line = new
        .iter()
        .filter(|c| (c.y[0] - 50.0).abs() > 1.5 && c.x[0] >= 15.0)
        .count();
    (beyond, closed, off_line)
}

/// The seed's Fig. 7 outcome of an offset run: (new cells past x = 17 m on y = 50 m, vertical
/// cells above 10 MPa of 8, new cells starting near the vertical fracture's tips: x >= 16 m,
/// y in [45, 49] or [51, 55]).
pub fn offset_outcome(r: &ExampleRun) -> (usize, usize, usize) {
    let new = r.new_cells();
    let beyond = new
        .iter()
        .filter(|c| c.x[0] >= 17.0 - 1e-6 && (c.y[0] - 50.0).abs() < 0.5)
        .count();
    let filled = r
        .cells
        .iter()
        .filter(|c| c.vertical() && c.pressure > 10e6)
        .count();
    let near_tips = new
        .iter()
        .filter(|c| {
            let y = 0.5 * (c.y[0] + c.y[1]);
            c.x[0] >= 16.0 - 1e-6 && ((45.0..=49.0).contains(&y) || (51.0..=55.0).contains(&y))
        })
        .count();
    (beyond, filled, near_tips)
}

/// Agreement of the quasi-static run `q` with the explicit run `e`: (explicit cells the
/// quasi-static run lacks, quasi-static cells the explicit lacks, mean and largest relative
/// creation-time difference (q - e) / e over the cells both open).
pub fn agreement(e: &ExampleRun, q: &ExampleRun) -> (usize, usize, f64, f64) {
    let (ne, nq) = (e.new_cells(), q.new_cells());
    let missing = ne.iter().filter(|c| !nq.iter().any(|d| d.same(c))).count();
    let extra = nq.iter().filter(|c| !ne.iter().any(|d| d.same(c))).count();
    let rel: Vec<f64> = ne
        .iter()
        .filter_map(|c| {
            nq.iter()
                .find(|d| d.same(c))
                .map(|d| (d.created - c.created) / c.created)
        })
        .collect();
    let mean = rel.iter().sum::<f64>() / rel.len().max(1) as f64;
    let worst = rel.iter().map(|x| x.abs()).fold(0.0, f64::max);
    (missing, extra, mean, worst)
}

pub fn example1(_quick: bool) -> anyhow::Result<CaseResult> {
    let end = 1.5;
    let mut res = CaseResult::default();
    let mut table = String::from("case,x0,x1,y0,y1,created_explicit_s,created_quasi_static_s\n");
    for (name, ron) in [("cross", CROSS_RON), ("offset", OFFSET_RON)] {
        let file = format!("scenarios/example1_{name}.ron");
        let runs = [
            example_run(ron, &file, end, &[]),
            example_run(ron, &file, end, &["time.solid_scheme=QuasiStatic".into()]),
        ];
        for (r, s) in runs.iter().zip(["explicit", "quasi_static"]) {
            res.check_max(
                format!("{name}: {s} run failed"),
                r.is_err() as u8 as f64,
                0.0,
            );
            if let Err(e) = r {
                res.notes.push(format!("{name}, {s}: {e:#}"));
            }
        }
        let [Ok(e), Ok(q)] = runs else {
            continue;
        };
        for (r, s) in [(&e, "explicit"), (&q, "quasi_static")] {
            check_fig7_outcome(&mut res, name, s, r);
        }
        check_scheme_agreement(&mut res, name, &e, &q);
        table += &cells_table(name, &e, &q);
    }
    example1_toughness(&mut res, end)?;
    res.files.push(("example1_cells.csv".into(), table));
    Ok(res)
}

/// Checks one strength-criterion run `r` of scene `name` (scheme `s`) for mass balance, new
/// cells and Fig. 7's outcome (cross: the fracture runs past x = 17 m on y = 50 m, the
/// vertical cells mostly closed, nothing off it; offset: nothing past x = 17 m on y = 50 m,
/// the vertical cells above 10 MPa, new cells near the vertical tips).
fn check_fig7_outcome(res: &mut CaseResult, name: &str, s: &str, r: &ExampleRun) {
    res.check_max(format!("{name}: mass balance, {s}"), r.balance, 1e-9);
    let new = r.new_cells();
    res.check_range(
        format!("{name}: new cells, {s}"),
        new.len() as f64,
        1.0,
        1e9,
    );
    if name == "cross" {
        let (beyond, closed, off) = cross_outcome(r);
        res.check_range(
            format!("{name}: new cells past x = 17 m, {s}"),
            beyond as f64,
            1.0,
            1e9,
        );
        // "Mostly closed" (R9): at least 6 of the 8 cells at the residual aperture.
        res.check_range(
            format!("{name}: vertical cells closed (of 8), {s}"),
            closed as f64,
            6.0,
            8.0,
        );
        res.check_max(
            format!("{name}: new cells off y = 50 m, {s}"),
            off as f64,
            0.0,
        );
    } else {
        let (beyond, filled, tips) = offset_outcome(r);
        res.check_max(
            format!("{name}: new cells past x = 17 m on y = 50 m, {s}"),
            beyond as f64,
            0.0,
        );
        res.check_range(
            format!("{name}: vertical cells above 10 MPa (of 8), {s}"),
            filled as f64,
            8.0,
            8.0,
        );
        res.check_range(
            format!("{name}: new cells near the vertical tips, {s}"),
            tips as f64,
            1.0,
            1e9,
        );
    }
}

/// Checks that the quasi-static run `q` of scene `name` agrees with the explicit run `e` (the
/// same cells, creation times and injected volume within the measured bounds) and adds the
/// rows (relative differences) and the note.
fn check_scheme_agreement(res: &mut CaseResult, name: &str, e: &ExampleRun, q: &ExampleRun) {
    let (missing, extra, mean, worst) = agreement(e, q);
    res.check_max(
        format!("{name}: explicit cells the quasi-static run lacks"),
        missing as f64,
        0.0,
    );
    // Extra cells only at the paths' ends: the quasi-static fracture runs ahead by the
    // inertia the explicit rock has (measured 6 of 33 in cross at 1.5 s, 0 in offset).
    res.check_max(
        format!("{name}: quasi-static cells the explicit run lacks / explicit cells"),
        extra as f64 / e.new_cells().len().max(1) as f64,
        0.25,
    );
    // Without inertia each face reaches the criterion earlier (measured 5-15 %).
    res.check_range(
        format!("{name}: mean creation time (q - e) / e"),
        mean,
        -0.25,
        0.05,
    );
    let dv = (q.injected - e.injected) / e.injected;
    // The pump (a pressure-limited curve) injects more into a longer fracture: with the
    // quasi-static path ahead (18 % more cells in cross at 1.5 s) the volume is 16 % more
    // there, 1.7 % in offset (the same cells).
    res.check_max(
        format!("{name}: injected volume |q - e| / e"),
        dv.abs(),
        0.2,
    );
    for (r, s) in [(e, "explicit"), (q, "quasi_static")] {
        for (m, err) in [("injected", dv.abs()), ("created", mean.abs())] {
            res.rows.push(Row {
                case: "example1",
                level: 0,
                h: 1.0,
                unknowns: r.unknowns,
                metric: format!("{name}_{m}_{s}"),
                error: err,
                wall_s: r.wall,
            });
        }
    }
    res.notes.push(format!(
            "{name}: explicit {} steps {:.1} s, {} new cells, injected {:.4} m^2; quasi-static {} steps {:.1} s ({:.2}x), {} new cells, injected {:.4} m^2; creation time (q - e) / e mean {:+.3}, largest {:.3}",
            e.steps, e.wall, e.new_cells().len(), e.injected,
            q.steps, q.wall, q.wall / e.wall, q.new_cells().len(), q.injected, mean, worst
        ));
}

/// The rows of `example1_cells.csv` for scene `name`: every new cell of the explicit run `e`
/// (ends in m, creation time in s, with the quasi-static run `q`'s where it has the cell),
/// then the cells only `q` has.
fn cells_table(name: &str, e: &ExampleRun, q: &ExampleRun) -> String {
    let mut table = String::new();
    for c in e.new_cells() {
        let tq = q.new_cells().iter().find(|d| d.same(&c)).map(|d| d.created);
        table += &format!(
            "{name},{},{},{},{},{:e},{}\n",
            c.x[0],
            c.x[1],
            c.y[0],
            c.y[1],
            c.created,
            tq.map_or(String::new(), |t| format!("{t:e}"))
        );
    }
    for c in q
        .new_cells()
        .iter()
        .filter(|c| !e.new_cells().iter().any(|d| d.same(c)))
    {
        table += &format!(
            "{name},{},{},{},{},,{:e}\n",
            c.x[0], c.x[1], c.y[0], c.y[1], c.created
        );
    }
    table
}

/// The toughness criterion on the same scenes, checked for Fig. 7's outcome (cross: the
/// fracture runs on past x = 17 m on y = 50 m and nothing starts off it; offset: nothing
/// past x = 17 m on y = 50 m, new fractures near the vertical fracture's tips):
/// K_Ic = 38.5 MPa sqrt(m), the toughness the seed's strength test acts like on this mesh
/// (3.5 (s0 + lambda T0) sqrt(h) with s0 = 10 MPa, lambda T0 = 1 MPa, h = 1 m), and the
/// seed's 1 MPa as the initiation strength away from tips, runs to `end` (s). The shipped
/// scenarios keep the strength criterion.
fn example1_toughness(res: &mut CaseResult, end: f64) -> anyhow::Result<()> {
    for (name, ron) in [("cross", CROSS_RON), ("offset", OFFSET_RON)] {
        let from = "strength: Some(1e6),";
        anyhow::ensure!(
            ron.contains(from),
            "example1_{name}.ron: no `{from}` to replace"
        );
        let text = ron.replace(
            from,
            &format!("criterion: Some(Toughness(k_ic: {EXAMPLE1_K_IC:e}, initiation: Some(1e6))),"),
        );
        let file = format!("scenarios/example1_{name}.ron (toughness criterion)");
        for (scheme, sets) in [
            ("explicit", vec![]),
            (
                "quasi-static",
                vec!["time.solid_scheme=QuasiStatic".to_string()],
            ),
        ] {
            match example_run(&text, &file, end, &sets) {
                Err(e) => {
                    res.check_max(format!("{name}: toughness run failed, {scheme}"), 1.0, 0.0);
                    res.notes
                        .push(format!("{name}, toughness, {scheme}: {e:#}"));
                }
                Ok(r) => check_toughness_run(res, name, scheme, &r),
            }
        }
    }
    Ok(())
}

/// Checks one toughness-criterion run `r` of scene `name` (scheme `scheme`) for mass balance
/// and Fig. 7's outcome, and adds its note.
fn check_toughness_run(res: &mut CaseResult, name: &str, scheme: &str, r: &ExampleRun) {
    res.check_max(
        format!("{name}: mass balance, toughness, {scheme}"),
        r.balance,
        1e-9,
    );
    let new = r.new_cells();
    let reach = new.iter().map(|c| c.x[1].max(c.x[0])).fold(0.0, f64::max);
    let outcome = if name == "cross" {
        let (beyond, closed, off) = cross_outcome(r);
        res.check_range(
            format!("{name}: new cells past x = 17 m, toughness, {scheme}"),
            beyond as f64,
            1.0,
            1e9,
        );
        res.check_max(
            format!("{name}: new cells off y = 50 m, toughness, {scheme}"),
            off as f64,
            0.0,
        );
        format!(
            "{beyond} new cells past x = 17 m on y = 50 m, {closed} of 8 vertical cells closed, {off} new cells off y = 50 m"
        )
    } else {
        let (beyond, filled, tips) = offset_outcome(r);
        res.check_max(
            format!("{name}: new cells past x = 17 m on y = 50 m, toughness, {scheme}"),
            beyond as f64,
            0.0,
        );
        res.check_range(
            format!("{name}: new cells near the vertical tips, toughness, {scheme}"),
            tips as f64,
            1.0,
            1e9,
        );
        format!(
            "{beyond} new cells past x = 17 m on y = 50 m, {filled} of 8 vertical cells above 10 MPa, {tips} new cells near the vertical tips"
        )
    };
    res.notes.push(format!(
                    "{name}, toughness criterion (K_Ic = {:.1} MPa sqrt(m), {scheme}): {} steps {:.1} s, {} new cells reaching x = {reach:.1} m, injected {:.4} m^2; {outcome}",
                    1e-6 * EXAMPLE1_K_IC, r.steps, r.wall, new.len(), r.injected
                ));
}

/// K_Ic of `example1`'s toughness-criterion runs, Pa sqrt(m).
pub const EXAMPLE1_K_IC: f64 = 38.5e6;

/// `time.selective_mass_scaling` against the unscaled explicit rock on the seed's Example I
/// (1.5 s, or 0.6 s with `--quick`): each scenario at factors 1 (the reference), 2, 4 and 8.
/// A fracture that grows in tenths of a second is the hard case for added inertia on its faces
/// (Example II's 60 s of slow filling is the easy one, README "Selective mass scaling"). Rows:
/// per factor, the injected volume's and the mean creation time's difference to the reference
/// (relative), with the wall time, so the plot is error against cost. Checks: the Fig. 7
/// outcome at every factor, mass balance, and the differences at factor 2 and 4 within the
/// bounds stated below (measured).
pub fn mass_scaling(quick: bool) -> anyhow::Result<CaseResult> {
    let end = if quick { 0.6 } else { 1.5 };
    let mut res = CaseResult::default();
    for (name, ron) in [("cross", CROSS_RON), ("offset", OFFSET_RON)] {
        let file = format!("scenarios/example1_{name}.ron");
        let reference = example_run(ron, &file, end, &[])?;
        for f in [1.0, 2.0, 4.0, 8.0] {
            let set = [format!("time.selective_mass_scaling=Some({f:?})")];
            let r = if f == 1.0 {
                None
            } else {
                match example_run(ron, &file, end, &set) {
                    Ok(r) => Some(r),
                    Err(e) => {
                        res.check_max(format!("{name} x{f}: run failed"), 1.0, 0.0);
                        res.notes.push(format!("{name} x{f}: {e:#}"));
                        continue;
                    }
                }
            };
            let r = r.as_ref().unwrap_or(&reference);
            res.check_max(format!("{name} x{f}: mass balance"), r.balance, 1e-9);
            if name == "cross" {
                let (beyond, _, off) = cross_outcome(r);
                res.check_range(
                    format!("{name} x{f}: new cells past x = 17 m"),
                    beyond as f64,
                    1.0,
                    1e9,
                );
                res.check_max(
                    format!("{name} x{f}: new cells off y = 50 m"),
                    off as f64,
                    0.0,
                );
            } else {
                let (beyond, _, tips) = offset_outcome(r);
                res.check_max(
                    format!("{name} x{f}: new cells past x = 17 m on y = 50 m"),
                    beyond as f64,
                    0.0,
                );
                res.check_range(
                    format!("{name} x{f}: new cells near the vertical tips"),
                    tips as f64,
                    1.0,
                    1e9,
                );
            }
            let dv = (r.injected - reference.injected) / reference.injected;
            let (missing, extra, mean, _) = agreement(&reference, r);
            if f > 1.0 && f <= 4.0 {
                res.check_max(
                    format!("{name} x{f}: injected volume |s - e| / e"),
                    dv.abs(),
                    MASS_SCALING_VOLUME,
                );
                res.check_max(
                    format!("{name} x{f}: mean creation time |s - e| / e"),
                    mean.abs(),
                    MASS_SCALING_CREATED,
                );
            }
            for (m, err) in [("injected", dv.abs()), ("created", mean.abs())] {
                res.rows.push(Row {
                    case: "mass_scaling",
                    level: f as usize,
                    h: f,
                    unknowns: r.unknowns,
                    metric: format!("{name}_{m}"),
                    error: err,
                    wall_s: r.wall,
                });
            }
            res.notes.push(format!(
                "{name} x{f}: {} steps {:.1} s ({:.2}x the reference's wall), {} new cells ({missing} of the reference's missing, {extra} extra), injected {:.4} m^2 ({dv:+.4}), creation time (s - e) / e mean {mean:+.3}",
                r.steps, r.wall, r.wall / reference.wall, r.new_cells().len(), r.injected
            ));
        }
    }
    Ok(res)
}

/// Bounds of `mass_scaling` at factors 2 and 4: the injected volume and the mean creation time
/// relative to the unscaled run. Measured (2026-12-03, 1.5 s): volume 0.4 % and 1.6 % (cross),
/// 0.06 % and 0.5 % (offset); creation time 0.1 % and 2.5 % (cross), 0.5 % and 3.0 % (offset).
/// About twice the largest, so a change that makes the faces' inertia matter more fails.
/// (At factor 8, unchecked: cross 7 % and 10 %, two of its 33 cells not yet open at 1.5 s.)
const MASS_SCALING_VOLUME: f64 = 0.03;
const MASS_SCALING_CREATED: f64 = 0.06;
