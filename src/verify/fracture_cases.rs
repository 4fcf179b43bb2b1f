//! Fracture verification cases (verification.md item 5): `sneddon`.

use super::{CaseResult, Row, observed_order};
use crate::scenario::{
    Boundary, Damping, End, FractureSpec, Material, MeshSpec, PreFracture, SideBc,
};
use crate::sim::{Finish, Simulation};
use crate::verify::solid_cases::scenario;
use std::time::Instant;

/// Opened area (m^2 per m), largest opening (m), wall time and unknowns of a pressurised straight crack of
/// half-length `a` (m) on a graded mesh of fine size `h` in a square domain of half-width `r`
/// with fixed edges, relaxed to a residual of 1e-8.
pub fn pressurised_crack(
    a: f64,
    h: f64,
    r: f64,
    p: f64,
    mat: Material,
) -> anyhow::Result<(f64, f64, f64, usize)> {
    let mut sc = scenario(
        "sneddon",
        MeshSpec::Graded {
            width: 2.0 * r,
            height: 2.0 * r,
            origin: [-r, -r],
            h,
            fine: [-1.2 * a, -0.2 * a, 1.2 * a, 0.2 * a],
            ratio: 1.15,
        },
        mat,
        Boundary::Sides {
            left: SideBc::Fixed,
            right: SideBc::Fixed,
            bottom: SideBc::Fixed,
            top: SideBc::Fixed,
        },
        End::Static {
            tol: 1e-8,
            min_steps: 10,
        },
        Damping::Local(0.8),
    );
    sc.fracture = Some(FractureSpec {
        strength: None,
        face_stress: Default::default(),
        residual_aperture: 5e-4,
        preexisting: vec![PreFracture {
            from: [-a, 0.0],
            to: [a, 0.0],
        }],
        pressure: Some(p),
        friction_deg: 30.0,
        normal_stiffness: None,
        shear_stiffness: None,
    });
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc, &[])?;
    let finish = sim.run(|_| {})?;
    anyhow::ensure!(
        finish == Finish::Converged,
        "sneddon: no static state (residual {:.3e})",
        sim.residual
    );
    let (mut area, mut wmax) = (0.0, 0.0f64);
    for j in sim.model.world.query::<&crate::components::Joint>().iter() {
        let (_, w, len) = crate::fractures::joint_opening(&sim.model, j);
        area += w * len;
        wmax = wmax.max(w);
    }
    Ok((
        area,
        wmax,
        t0.elapsed().as_secs_f64(),
        2 * sim.view.n_nodes(),
    ))
}

/// Sneddon's pressurised crack (plane strain, uniform pressure p on a crack of half-length a):
/// w(x) = (4p/E') sqrt(a^2 - x^2), opened area 2 pi p a^2 / E', w_max = 4 p a / E'. Graded mesh
/// refined around the crack, domain 40a x 40a with fixed edges. Errors: relative error of the
/// opened area and of the largest opening (at the centre; the sampled maximum is the joint
/// nearest x = 0). Targets: area within 5 % at a/h = 20 and 1.5 % at a/h = 80.
pub fn sneddon(quick: bool) -> anyhow::Result<CaseResult> {
    let ratios: &[f64] = if quick {
        &[10.0, 20.0]
    } else {
        &[10.0, 20.0, 40.0]
    };
    let (a, p) = (1.0, 1e6);
    let mat = Material {
        young: 20e9,
        poisson: 0.2,
        density: 2700.0,
    };
    let e_prime = mat.young / (1.0 - mat.poisson * mat.poisson);
    let area_exact = 2.0 * std::f64::consts::PI * p * a * a / e_prime;
    let wmax_exact = 4.0 * p * a / e_prime;
    let mut res = CaseResult::default();
    for (level, &ah) in ratios.iter().enumerate() {
        let h = a / ah;
        let (area, wmax, wall, unknowns) = pressurised_crack(a, h, 20.0 * a, p, mat)?;
        for (metric, err) in [
            ("area", (area - area_exact) / area_exact),
            ("max_opening", (wmax - wmax_exact) / wmax_exact),
        ] {
            res.rows.push(Row {
                case: "sneddon",
                level,
                h,
                unknowns,
                metric: metric.into(),
                error: err.abs(),
                wall_s: wall,
            });
        }
        if (ah - 20.0).abs() < 1e-9 {
            res.check_max(
                "area error at a/h = 20",
                ((area - area_exact) / area_exact).abs(),
                0.05,
            );
        }
    }
    let order = observed_order(&res.errors("area"));
    res.check_range("area observed order", order, 0.7, 1.5);
    Ok(res)
}
