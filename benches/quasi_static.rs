//! The quasi-static scheme's linear algebra on the seed's 100 m block (20,000 elements, in-situ
//! boundary displacements): one equilibrium step that refactorises (numeric Cholesky with the
//! symbolic analysis reused, then a solve) and one that reuses the cached factor (solve only),
//! each including its two force evaluations. The load factor alternates between 0.5 and 1, so
//! every step has one Newton iteration.
//!
//! Frictional: the closed 20-degree crack of `verify slip_inclined` on its conforming mesh at
//! b/h = 80 (160 joints, all sliding), solved to equilibrium from the unloaded crack in one
//! step, by each linear solver (`time.linear_solver`): `Cholesky` (symmetric tangent, the
//! sliding joints' Coulomb term by Sherman-Morrison-Woodbury: 160 extra solves and a 160 x 160
//! LU per Newton iteration) and `Lu` (the full unsymmetric matrix with the exact joint tangent,
//! one sparse LU per iteration).
//!
//! Example II: a step of the shipped network's stimulation on the quasi-static rock with
//! implicit dynamics (`time.inertia: BackwardEuler`, no selective mass scaling; about 28,000
//! unknowns, some hundred joints sliding), after 20 steps from the start, each Newton
//! iteration's direction from the full matrix's sparse LU: without pivoting on the pattern's
//! symmetric fill (`static_pivots`, the default, `hydrofrac_core::static_lu`), or faer's LU
//! with partial pivoting factored at every iteration (`pivoted_factor_every_iteration`) or
//! with an earlier factor reused as BiCGSTAB's preconditioner while that converges in a few
//! iterations (`pivoted_reuse_factor`, the default before the static pivots). Each sample is
//! one step (about 4 Newton iterations; the counts are printed), so the rows' ratios are the
//! cost ratios of a Newton iteration. The state moves on with every step, the same way in
//! every row. `HYDROFRAC_BENCH_EXAMPLE2=0` skips it (a minute of set-up).
//!
//! Run: `cargo bench --bench quasi_static`.

#[macro_use]
mod common;

use criterion::Criterion;
use hydrofrac::scenario::{Damping, End, LinearSolver, SolidScheme};
use hydrofrac::sim::Simulation;
use hydrofrac::systems::quasi_static::{QuasiStatic, StepEnd, Systems, solve};
use hydrofrac::verify::solid_cases::seed_block;

fn quasi_static(c: &mut Criterion) {
    let mut sc = seed_block(
        1.0,
        End::Static {
            tol: 1e-9,
            min_steps: 1,
        },
        Damping::Local(0.8),
    );
    sc.time.solid_scheme = SolidScheme::QuasiStatic;
    let sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    let mut v = sim.solid().clone();
    let p = sim.params().clone();
    assert_eq!(v.n_elems(), 20_000);
    let mut qs = QuasiStatic::new(Systems {
        load: true,
        contact: true,
        fluid: false,
    });
    let mut group = c.benchmark_group("quasi_static_20k");
    common::ten_samples(&mut group, 500, 3);
    let mut k = 0u64;
    let mut step = |qs: &mut QuasiStatic, refactor: bool| {
        k += 1;
        let lf = if k.is_multiple_of(2) { 1.0 } else { 0.5 };
        if refactor {
            qs.forget_factor();
        }
        solve(
            &mut v,
            qs,
            None,
            None,
            &p,
            StepEnd {
                step: k,
                time: 0.0,
                lf,
                dt: 0.0,
            },
        )
        .unwrap()
    };
    step(&mut qs, true);
    group.bench_function("factorise_and_solve", |b| b.iter(|| step(&mut qs, true)));
    group.bench_function("solve_cached_factor", |b| b.iter(|| step(&mut qs, false)));
    group.finish();
    eprintln!("{:?}", qs.counts);
}

fn frictional(c: &mut Criterion) {
    use hydrofrac::verify::slip_cases::{R, STIFFNESS_FACTOR, SlipMesh, slip_scenario};
    let sc = slip_scenario(SlipMesh::Conforming, 1.0 / 80.0, R, STIFFNESS_FACTOR);
    let sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    let (v0, p) = (sim.solid().clone(), sim.params().clone());
    let mut group = c.benchmark_group("quasi_static_slip_160_joints");
    common::ten_samples(&mut group, 500, 5);
    for (name, linear) in [
        ("cholesky_smw", LinearSolver::Cholesky),
        ("sparse_lu", LinearSolver::Lu),
    ] {
        let mut qs = QuasiStatic::new(Systems {
            load: true,
            contact: true,
            fluid: false,
        });
        qs.linear = linear;
        group.bench_function(name, |b| {
            b.iter(|| {
                let mut v = v0.clone();
                solve(
                    &mut v,
                    &mut qs,
                    None,
                    None,
                    &p,
                    StepEnd {
                        step: 1,
                        time: 1.0,
                        lf: 1.0,
                        dt: 0.0,
                    },
                )
                .unwrap()
            })
        });
        eprintln!("{name}: {:?}", qs.counts);
    }
    group.finish();
}

fn example2(c: &mut Criterion) {
    use hydrofrac::scenario::Scenario;
    if std::env::var("HYDROFRAC_BENCH_EXAMPLE2").as_deref() == Ok("0") {
        return;
    }
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/example2.ron");
    let overrides: Vec<String> = [
        "time.solid_scheme=\"QuasiStatic\"",
        "time.inertia=\"BackwardEuler\"",
        "time.selective_mass_scaling=None",
        "time.end=Time(60.0)",
    ]
    .map(String::from)
    .to_vec();
    let mut group = c.benchmark_group("example2_quasi_static_step");
    common::ten_samples(&mut group, 1, 20);
    let tol = Some(hydrofrac::static_lu::PIVOT_TOL);
    for (name, static_pivots, reuse) in [
        ("static_pivots", tol, false),
        ("pivoted_factor_every_iteration", None, false),
        ("pivoted_reuse_factor", None, true),
    ] {
        let sc = Scenario::load(&path, &overrides).unwrap();
        let mut sim = Simulation::new(sc, &[]).unwrap();
        let qs = sim.quasi_static_mut().unwrap();
        (qs.static_pivots, qs.reuse_lu) = (static_pivots, reuse);
        for _ in 0..20 {
            sim.step_once().unwrap();
        }
        let before = sim.quasi_static_counts().unwrap();
        group.bench_function(name, |b| b.iter(|| sim.step_once().unwrap()));
        let after = sim.quasi_static_counts().unwrap();
        let steps = (after.steps - before.steps).max(1);
        eprintln!(
            "{name}: {} steps, {:.2} Newton iterations per step, {} factorisations ({} with \
             pivoting), {} reuses ({} BiCGSTAB iterations)",
            steps,
            (after.newton_iterations - before.newton_iterations) as f64 / steps as f64,
            after.lu_factorisations - before.lu_factorisations,
            after.lu_pivoted - before.lu_pivoted,
            after.lu_reused - before.lu_reused,
            after.krylov_iterations - before.krylov_iterations,
        );
    }
    group.finish();
}

bench_main!(quasi_static, frictional, example2);
