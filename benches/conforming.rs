//! The conforming mesher (`mesh: Conforming`, `src/conforming.rs`) on the case: a
//! 100 m x 100 m domain at h = 1 m (h_far = 8 m, grading 0.1, smallest angle 25 degrees)
//! around the 100 seeded fractures of `verify conforming_mesh` (15-40 m at 60 and 150 +-15
//! degrees; about 13,800 nodes and 27,300 triangles), and the same at h = 0.5 m.
//!
//! Run: `cargo bench --bench conforming`.

#[macro_use]
mod common;

use criterion::Criterion;
use hydrofrac::scenario::MeshSpec;
use hydrofrac::setup::build_mesh_around;
use hydrofrac::verify::conforming_cases::network_100;

fn bench(c: &mut Criterion) {
    let segs: Vec<([f64; 2], [f64; 2])> = network_100()
        .generate()
        .iter()
        .map(|f| (f.from, f.to))
        .collect();
    let mut g = c.benchmark_group("conforming");
    common::ten_samples(&mut g, 300, 3);
    for h in [1.0, 0.5] {
        let spec = MeshSpec::Conforming {
            width: 100.0,
            height: 100.0,
            origin: [0.0, 0.0],
            h,
            h_far: Some(8.0 * h),
            min_angle_deg: 25.0,
            merge: 0.25,
            grading: 0.1,
            follow: Vec::new(),
        };
        g.bench_function(
            format!("mesh_100_fractures_h_{}cm", (100.0 * h) as u32),
            |b| b.iter(|| build_mesh_around(&spec, &segs).unwrap()),
        );
    }
    g.finish();
}

bench_main!(bench);
