use hydrofrac::verify::slip_cases::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let bh: f64 = args[1].parse().unwrap();
    let k: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(STIFFNESS_FACTOR);
    match slip_run_with(if std::env::var_os("SNAP").is_some() { SlipMesh::Snapped } else { SlipMesh::Conforming }, bh, R, k) {
        Ok(r) => println!("bh {bh}: max slip err {:+.4}% prof {:.4}% sliding {:.3} joints {} wall {:.2} unknowns {} s0 {:.6e}", 100.0*r.max_slip_error(), 100.0*r.profile_error(), r.sliding_fraction(), r.joints.len(), r.wall_s, r.unknowns, r.joints[0].slip),
        Err(e) => println!("bh {bh}: ERR {e:#}"),
    }
}
