//! Test support: scenario texts that several integration tests share (each test file pulls it
//! in with `#[path = "support/scenes.rs"] mod scenes;` and uses what it needs).
#![allow(dead_code)]

/// A block cut by a horizontal fracture across its whole width (8 m x 4 m, h = 1 m, fracture
/// at y = 2 m, friction 30 degrees), pressed by 10 MPa and sheared by `tau` (Pa) on its top and
/// sides, ending at `end` (RON, e.g. `Static(tol: 1e-9)`).
pub fn friction_block(tau: f64, end: &str) -> String {
    format!(
        r#"(
        name: "friction",
        mesh: Regular(width: 8.0, height: 4.0, h: 1.0),
        material: (young: 20e9, poisson: 0.2, density: 2700.0),
        boundary: Sides(
            bottom: Fixed,
            top: Traction(normal: -10e6, shear: -{tau}),
            left: Traction(normal: 0.0, shear: {tau}),
            right: Traction(normal: 0.0, shear: {tau}),
        ),
        fracture: Some((preexisting: [(from: (0.0, 2.0), to: (8.0, 2.0))], friction_deg: 30.0)),
        time: (end: {end}, max_steps: 400000),
    )"#
    )
}

/// A closed crack inclined at 20 degrees on a graded mesh (unequal elements around it), under
/// -10 / -20 MPa with friction 10 degrees, for 5 ms.
pub const INCLINED_CRACK: &str = r#"(
    name: "inclined",
    mesh: Graded(width: 40.0, height: 40.0, origin: (-20.0, -20.0), h: 0.2,
                 fine: (-1.2, -0.6, 1.2, 0.6), ratio: 1.15),
    material: (young: 20e9, poisson: 0.2, density: 2700.0),
    boundary: InSitu(sxx: -10e6, syy: -20e6),
    initial_state: InSitu,
    fracture: Some((preexisting: [(from: (-0.94, -0.342), to: (0.94, 0.342))], friction_deg: 10.0)),
    time: (end: Time(0.005)),
)"#;

/// A 20 m x 10 m plate (h = 0.5 m) with a 4 m notch from its left side at mid-height, pulled
/// by 2 MPa on top and bottom, fracture strength `strength` (RON, e.g. `Some(4e6)`), 20 ms.
pub fn notched_plate(strength: &str) -> String {
    format!(
        r#"(
        name: "notch",
        mesh: Regular(width: 20.0, height: 10.0, h: 0.5),
        material: (young: 20e9, poisson: 0.2, density: 2700.0),
        boundary: Sides(top: Traction(normal: 2e6, shear: 0.0), bottom: Traction(normal: 2e6, shear: 0.0)),
        pins: [(at: (20.0, 0.0), ux: 0.0, uy: 0.0), (at: (20.0, 10.0), ux: 0.0)],
        fracture: Some((strength: {strength}, preexisting: [(from: (0.0, 5.0), to: (4.0, 5.0))])),
        time: (end: Time(0.02)),
    )"#
    )
}

/// A pump (P_max = 30 MPa) drives water into a 10 m pre-existing fracture from the left side of
/// a 40 m x 30 m rock (h = 1 m) under -20 / -10 MPa; `extra` is appended inside `time: (...)`.
pub fn pumped_fracture(end: f64, extra: &str) -> String {
    format!(
        r#"(
        name: "coupled",
        mesh: Regular(width: 40.0, height: 30.0, h: 1.0),
        material: (young: 20e9, poisson: 0.2, density: 2700.0),
        boundary: InSitu(sxx: -20e6, syy: -10e6),
        initial_state: InSitu,
        fracture: Some((strength: Some(1e6), preexisting: [(from: (0.0, 15.0), to: (10.0, 15.0))],
            friction_deg: 45.0, normal_stiffness: Some(20e9), shear_stiffness: Some(8.3e9))),
        flow_boundaries: [(name: "pump", at: Node((0.0, 15.0)), kind: Pump(p_max: 30e6, q_half: 2.0))],
        time: (end: Time({end}) {extra}),
    )"#
    )
}
