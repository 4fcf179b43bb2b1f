//! KGD propagation (`docs/verification.md` R6), the shipped `scenarios/kgd.ron` with the implicit
//! flow scheme at h = 2 and 1 m (about 45 s). The engine converges to the viscosity-dominated
//! similarity solution as h falls (the strength criterion acts like a toughness that vanishes
//! with h; README, "KGD"): each of the half-length, well-opening and net-pressure errors must
//! fall at least 1.5x from h = 2 to h = 1 m (measured 2.3x, 4.0x, 4.1x), the h = 1 m errors
//! must stay inside 20 % / 15 % / 30 % (measured -12 %, +9 %, +20 %; a regression in the
//! coupling or the criterion moves them by far more), and mass is conserved to 1e-9.
//! `hydrofrac verify kgd` adds h = 0.5 and 0.25 m and the explicit scheme, and checks the 5 %
//! target at h = 0.25 m (measured +1.8 %, -0.4 %, +3.8 %); too long for CI (about 5 min per
//! scheme at h = 0.25 m).

use hydrofrac::verify::coupled_cases::kgd_run;

#[test]
fn kgd_converges_with_the_mesh() {
    let coarse = kgd_run(2.0, "Implicit", &[]).unwrap();
    let fine = kgd_run(1.0, "Implicit", &[]).unwrap();
    for r in [&coarse, &fine] {
        assert!(r.balance < 1e-9, "mass balance {:e}", r.balance);
    }
    let (ec, ef) = (coarse.errors(), fine.errors());
    for (k, what) in ["half-length", "well opening", "net pressure"]
        .iter()
        .enumerate()
    {
        assert!(
            ef[k].abs() * 1.5 <= ec[k].abs(),
            "{what}: error {:.3} at h = 2 m, {:.3} at h = 1 m",
            ec[k],
            ef[k]
        );
    }
    assert!(
        ef[0].abs() < 0.20 && ef[1].abs() < 0.15 && ef[2].abs() < 0.30,
        "{ef:?}"
    );
}
