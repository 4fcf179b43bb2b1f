//! The state of a finished coupled run as bits, for the determinism tests.

use hydrofrac::sim::{Finish, Simulation};

/// What a determinism test compares, as bits: displacements, fluid excess masses, the split
/// count, the steps taken and the first boundary's injected volume.
pub type RunBits = (Vec<u64>, Vec<u64>, u64, u64, u64);

/// `f` on a rayon pool of `threads` threads.
pub fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// Build a simulation with `make` and run it to its end time in a pool of `threads` threads.
pub fn run_bits(threads: usize, make: impl Fn() -> Simulation + Send + Sync) -> RunBits {
    on_threads(threads, || {
        let mut sim = make();
        assert_eq!(sim.run(|_| {}).unwrap(), Finish::EndTime);
        let f = sim.flow().unwrap();
        let u = sim
            .solid()
            .u
            .iter()
            .flat_map(|x| x.map(f64::to_bits))
            .collect();
        let e = f.view.excess.iter().map(|x| x.to_bits()).collect();
        (
            u,
            e,
            sim.fracture().splits as u64,
            sim.clock().step,
            f.view.bcs[0].volume_in.to_bits(),
        )
    })
}
