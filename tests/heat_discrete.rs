//! The discrete heat model (`hydrofrac::reservoir::discrete`, `docs/heat_discrete.md`):
//! Lauwerier at one resolution, the energy balance checked from the outputs, the Stehfest
//! inversion on known pairs, the fracture-rock conductances on and off grid lines, bounds on a
//! real network's temperatures, bad inputs named, and same bits twice and on 1 and 2 threads.

use hydrofrac::reservoir::discrete::{
    DiscreteModel, DiscreteSpec, RockGrid, TimeStep, run_discrete,
};
use hydrofrac::reservoir::{NetworkFlow, ReservoirError, ThermalProps};
use hydrofrac::verify::flow_cases::erfc;
use hydrofrac::verify::heat_discrete_cases::{
    APERTURE, FLOW, LEN, T_HALF, T_INJ, T0, compare, lattice_network, lauwerier, level,
    parallel_fractures, spec, stehfest,
};

/// Level 2 of the `lauwerier` case (40 cells, 0.1 m at the fracture): measured 9.1e-3 of the
/// temperature drop (the error is first order, 4.4e-3 at level 3); required 1.5e-2.
#[test]
fn lauwerier_level_2() {
    let p = ThermalProps::granite_water();
    let (run, _, err) = compare(&[0.0], 0.0, -20.0, 20.0, &level(2), &|t| {
        lauwerier(LEN, t, FLOW, APERTURE, &p)
    })
    .unwrap();
    assert!(
        err <= 1.5e-2,
        "outlet error {err:.3e} of the drop (allowed 1.5e-2)"
    );
    assert!(run.energy_balance.relative_error <= 1e-9);
    // The outlet cools monotonically towards the injection temperature.
    for w in run.production_temperature.windows(2) {
        assert!(w[1] <= w[0] + 1e-9, "{w:?}");
    }
}

fn small_network_spec() -> (DiscreteSpec, NetworkFlow) {
    let flow = lattice_network(8, 20.0, 1e5, 7).unwrap();
    let mut sp = spec(&[], 0.0, 0.0, 20.0, &level(0), 3.0e7);
    sp.grid = RockGrid::from_grid2(&hydrofrac::reservoir::Grid2 {
        origin: [-1.0, -1.0],
        size: [22.0, 22.0],
        n: [22, 22],
    });
    sp.output_times = vec![1e6, 3.0e7];
    (sp, flow)
}

/// Stored heat from the final snapshot and capacities, injected heat from the rates, produced
/// heat from the production-temperature series: the balance to 1e-9, computed here
/// independently of the run's own accounts. Temperatures stay within [T_inj, T0] (the matrix
/// is an M-matrix: backward Euler keeps the maximum principle).
#[test]
fn energy_balance_from_outputs() {
    let (sp, flow) = small_network_spec();
    assert!(flow.mass_imbalance() < 1e-9);
    let model = DiscreteModel::new(&sp, &flow).unwrap();
    let cap = model.capacities().to_vec();
    let run = run_discrete(&sp, &flow).unwrap();
    let last = run.snapshots.last().unwrap();
    assert_eq!(last.time, sp.end_time);
    let stored: f64 = cap
        .iter()
        .zip(last.cell_temperature.iter().chain(&last.rock_temperature))
        .map(|(c, t)| c * (t - T0))
        .sum();
    let rwcw = sp.props.fluid_rho_c();
    let q_in: f64 = flow
        .boundary
        .iter()
        .filter(|b| b.1 > 0.0)
        .map(|b| b.1)
        .sum();
    let q_out: f64 = -flow
        .boundary
        .iter()
        .filter(|b| b.1 < 0.0)
        .map(|b| b.1)
        .sum::<f64>();
    let injected = rwcw * q_in * (T_INJ - T0) * sp.end_time;
    let mut produced = 0.0;
    let mut t_prev = 0.0;
    for (t, tp) in run.times.iter().zip(&run.production_temperature) {
        produced += (t - t_prev) * rwcw * q_out * (tp - T0);
        t_prev = *t;
    }
    let rel = (stored - (injected - produced)).abs() / injected.abs();
    assert!(
        rel <= 1e-9,
        "stored {stored:e}, injected {injected:e}, produced {produced:e}: relative error {rel:e}"
    );
    assert!(run.energy_balance.relative_error <= 1e-9);
    assert!(
        (run.energy_balance.stored - stored).abs() <= 1e-9 * stored.abs(),
        "{} vs {stored}",
        run.energy_balance.stored
    );
    for t in last.cell_temperature.iter().chain(&last.rock_temperature) {
        assert!(
            (T_INJ - 1e-9..=T0 + 1e-9).contains(t),
            "temperature {t} outside [{T_INJ}, {T0}]"
        );
    }
    // Heat was extracted: the rock cooled.
    assert!(stored < 0.0 && run.cumulative_heat.last().unwrap() > &0.0);
}

/// Stehfest (14 terms) against exact pairs: erfc(a / (2 sqrt t)) <-> exp(-a sqrt s) / s and
/// exp(-t) <-> 1 / (s + 1); measured 1.3e-5 and 1.5e-5 at worst, required 1e-4.
#[test]
fn stehfest_pairs() {
    let mut worst: f64 = 0.0;
    for &a in &[0.5, 1.0, 3.0] {
        for &t in &[0.1, 0.5, 1.0, 4.0, 20.0] {
            let f = stehfest(|s| (-a * s.sqrt()).exp() / s, t, 14);
            let exact = erfc(a / (2.0 * f64::sqrt(t)));
            worst = worst.max((f - exact).abs());
            assert!((f - exact).abs() <= 1e-4, "a {a}, t {t}: {f} vs {exact}");
        }
    }
    eprintln!("Stehfest erfc pair: worst {worst:.2e}");
    for &t in &[0.1, 1.0, 3.0] {
        let f = stehfest(|s| 1.0 / (s + 1.0), t, 14);
        eprintln!(
            "Stehfest exp pair t {t}: error {:.2e}",
            (f - (-t).exp()).abs()
        );
        assert!((f - (-t).exp()).abs() <= 1e-4, "t {t}: {f}");
    }
}

/// A fracture on a grid line exchanges 2 K w / h with each side; one through block centres
/// becomes their node (the floor distance 1e-3 of the spacing) and keeps K w / h to the next
/// centres; the sum over a straight fracture's pieces covers its length.
#[test]
fn exchange_conductances() {
    let p = ThermalProps::granite_water();
    let k = p.rock_conductivity;
    let grid = RockGrid {
        x: (0..=10).map(|i| i as f64).collect(),
        y: (0..=4).map(|j| j as f64 * 0.5).collect(),
    };
    let mk = |y: f64| {
        let flow = parallel_fractures(&[y], 10.0, 5, APERTURE, FLOW);
        let sp = DiscreteSpec {
            grid: grid.clone(),
            props: p,
            initial_temperature: T0,
            injection_temperature: T_INJ,
            end_time: 1.0,
            time_step: TimeStep::Fixed { dt: 1.0 },
            output_times: vec![],
        };
        DiscreteModel::new(&sp, &flow).unwrap()
    };
    // On the line y = 1 (between rows 1 and 2, h = 0.5): 10 pieces x 2 sides, 2 K w / h each.
    let m = mk(1.0);
    assert_eq!(m.exchanges().len(), 20);
    for &(_, b, g) in m.exchanges() {
        assert!((g - 2.0 * k * 1.0 / 0.5).abs() <= 1e-12 * g, "{g}");
        assert!(b / 10 == 1 || b / 10 == 2, "block {b}");
    }
    // Through the centres of row 1 (y = 0.75): node of row 1, K w / h to row 2.
    let m = mk(0.75);
    let to_row = |r: usize| -> Vec<f64> {
        m.exchanges()
            .iter()
            .filter(|e| e.1 / 10 == r)
            .map(|e| e.2)
            .collect()
    };
    assert!(to_row(1).iter().all(|&g| g >= 999.0 * k * 1.0 / 0.5));
    assert!(to_row(2).iter().all(|&g| (g - k / 0.5).abs() <= 1e-9 * g));
    // Between centre and face (y = 0.875, a quarter of the spacing from row 1's centre).
    let m = mk(0.875);
    for &(_, b, g) in m.exchanges() {
        let d = if b / 10 == 1 { 0.125 } else { 0.375 };
        assert!((g - k / d).abs() <= 1e-9 * g, "block {b}: {g}");
    }
}

fn invalid_field(r: Result<impl std::fmt::Debug, ReservoirError>) -> String {
    match r {
        Err(ReservoirError::Invalid { field, .. }) => field,
        other => panic!("expected ReservoirError::Invalid, got {other:?}"),
    }
}

#[test]
fn bad_inputs_are_named() {
    let (sp, flow) = small_network_spec();
    let mut s = sp.clone();
    s.initial_temperature = f64::NAN;
    assert_eq!(
        invalid_field(run_discrete(&s, &flow)),
        "initial_temperature"
    );
    let mut s = sp.clone();
    s.injection_temperature = -1.0;
    assert_eq!(
        invalid_field(run_discrete(&s, &flow)),
        "injection_temperature"
    );
    let mut s = sp.clone();
    s.time_step = TimeStep::Fixed { dt: -1.0 };
    assert_eq!(invalid_field(run_discrete(&s, &flow)), "time_step.dt");
    let mut s = sp.clone();
    s.output_times = vec![2.0, 1.0];
    assert_eq!(invalid_field(run_discrete(&s, &flow)), "output_times");
    let mut s = sp.clone();
    s.props.rock_conductivity = 0.0;
    assert_eq!(
        invalid_field(run_discrete(&s, &flow)),
        "props.rock_conductivity"
    );
    // A node outside the grid.
    let mut f = flow.clone();
    f.nodes[0] = [-5.0, 3.0];
    let err = run_discrete(&sp, &f).unwrap_err();
    assert!(err.to_string().contains("outside the rock grid"), "{err}");
    assert_eq!(invalid_field(Err::<(), _>(err)), "flow.cells");
    // Unbalanced fluxes.
    let mut f = flow.clone();
    f.fluxes[3].2 *= 1.5;
    let err = run_discrete(&sp, &f).unwrap_err();
    assert!(err.to_string().contains("imbalance"), "{err}");
    assert_eq!(invalid_field(Err::<(), _>(err)), "flow.fluxes");
    // No producer.
    let mut f = flow.clone();
    f.boundary.retain(|b| b.1 > 0.0);
    assert_eq!(invalid_field(run_discrete(&sp, &f)), "flow.boundary");
    // A bad grid.
    let mut s = sp.clone();
    s.grid.x.swap(1, 2);
    assert_eq!(invalid_field(run_discrete(&s, &flow)), "grid.x");
    // The spec rejects unknown fields.
    let text = ron::to_string(&sp).unwrap();
    assert!(ron::from_str::<DiscreteSpec>(&text).is_ok());
    let bad = text.replacen("end_time", "end_tme", 1);
    assert!(ron::from_str::<DiscreteSpec>(&bad).is_err());
}

/// Same bits twice, and inside rayon pools of 1 and 2 threads.
#[test]
fn deterministic() {
    let (sp, flow) = small_network_spec();
    let a = run_discrete(&sp, &flow).unwrap();
    let b = run_discrete(&sp, &flow).unwrap();
    assert_eq!(a, b);
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let c = pool.install(|| run_discrete(&sp, &flow).unwrap());
        assert_eq!(a, c, "{threads} threads");
    }
    assert!(a.times.len() > 10 && a.production_temperature.iter().all(|t| t.is_finite()));
    let _ = T_HALF;
}
