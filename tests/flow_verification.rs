//! Fracture-network flow verification (`docs/verification.md` R10-R13) at test resolutions. Every
//! check's tolerance and its reason are in `src/verify/flow_cases.rs`.

use hydrofrac::flow::{FlowParams, pressure_of};
use hydrofrac::scenario::{Coords, End, FlowBcKind, FlowTarget, InitialFluid};
use hydrofrac::sim::Simulation;
use hydrofrac::verify::{CaseResult, flow_cases};

fn assert_case(name: &str, res: &CaseResult) {
    let failed = res.failures();
    assert!(failed.is_empty(), "{name} failed:\n{}", failed.join("\n"));
}

#[test]
fn cubic_law_single_x_and_t_junctions() {
    assert_case("cubic_law", &flow_cases::cubic_law(true).unwrap());
}

#[test]
fn pressure_diffusion_second_order() {
    let res = flow_cases::diffusion(true).unwrap();
    assert_case("diffusion", &res);
    assert_eq!(res.errors("closed_end_series_explicit").len(), 4);
    assert_eq!(res.errors("closed_end_series_implicit").len(), 4);
    assert_eq!(res.errors("time_error_implicit_dt").len(), 5);
}

#[test]
fn mass_balance_with_pump_switching() {
    assert_case("mass_balance", &flow_cases::mass_balance(true).unwrap());
}

#[test]
fn pump_operating_point() {
    assert_case("pump_curve", &flow_cases::pump_curve(true).unwrap());
}

#[test]
fn explicit_steady_state_matches_direct_solve_on_random_network() {
    assert_case("steady", &flow_cases::steady(true).unwrap());
}

#[test]
fn automatic_flow_step_is_stable_and_over_limit_is_caught() {
    assert_case("flow_stability", &flow_cases::flow_stability(true).unwrap());
}

/// The maximum-principle check of `flow_stability` can fail: stepping the kernel directly at
/// 3x the bound (bypassing the monitor) drives pressures outside the initial/boundary range.
#[test]
fn over_limit_kernel_violates_the_maximum_principle() {
    let sc = flow_cases::flow_scenario(
        "unstable",
        hydrofrac::verify::flow_cases::net(
            vec![hydrofrac::network::Fracture {
                from: [0.0, 0.0],
                to: [10.0, 0.0],
                aperture: 1e-4,
            }],
            None,
            0.5,
        ),
        vec![flow_cases::bc(
            "step",
            FlowTarget::Node(Coords::two([0.0, 0.0])),
            FlowBcKind::Pressure(2e6),
        )],
        InitialFluid::Full(1e6),
        End::Time(1.0),
        flow_cases::WATER,
    );
    let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    let p: FlowParams = sim.params().fluid;
    let specs = sim.scenario().flow_boundaries.clone();
    let f = sim.flow_mut().unwrap();
    let dt = 3.0 * f.dt_crit;
    let mut over = 0.0f64;
    for k in 0..200 {
        hydrofrac::systems::flow::flow_step(&mut f.view, &p, &specs, dt, k as f64 * dt);
        for c in 0..f.view.n_cells() {
            let pc = pressure_of(f.view.excess[c], f.view.volume[c], &p);
            over = over.max((pc - 2e6).max(1e6 - pc) / 1e6);
        }
    }
    assert!(
        over > 0.1,
        "an over-limit step stayed within bounds ({over})"
    );
}
