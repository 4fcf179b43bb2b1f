use hydrofrac::verify::coupled_cases::{Regime, kgd_run_in};
#[test]
fn tmp_kv() {
    for k in [2.4e6, 24e6] {
        for h in [2.0, 1.0] {
            let r = kgd_run_in(h, "QuasiStatic", &[], Regime::ViscosityToughness(k)).unwrap();
            let e = r.errors();
            eprintln!(
                "K_Ic {k:e} h {h}: l {:.2} tracked {:.2} w0 {:.4} p0 {:.3e}; exact {:?}; err {:+.3} {:+.3} {:+.3} wall {:.2}",
                r.l,
                r.l_tracked,
                r.w0 * 1e3,
                r.p0,
                r.exact,
                e[0],
                e[1],
                e[2],
                r.wall
            );
        }
    }
}
