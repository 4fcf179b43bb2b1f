//! The explicit scheme's internal force per element and step, TET4 beside the CST, in one run
//! (issue 38's target: TET4 under 12 ns per element per step on 1 thread, the CST about 11).
//! Both kernels on flat arrays (`core/src/tet4.rs`, `core/src/element.rs`): gather the nodal
//! displacements, strain, Hooke, nodal forces, scatter; serial, one thread; element geometry
//! precomputed as the engine keeps it. Beside them (`engine/...`), the engine's system itself,
//! `systems::solid::internal_force` on the dense views of a 3D and a 2D model (generic over
//! the element kind: per-element forces, then the gather by node), in a one-thread pool.
//!
//! Run: `cargo bench --bench tet4_force` (criterion reports Melem/s; ns/element = 1000 / that).
//! Set HYDROFRAC_BENCH_TETS=12,24 to pick the boxes (cubes per side; 6 tetrahedra per cube).

#[macro_use]
mod common;

use criterion::{BenchmarkId, Criterion, Throughput};
use hydrofrac::dim::Tet4;
use hydrofrac::element::{SolidParams, cst_forces, cst_stress};
use hydrofrac::mesh::TriMesh;
use hydrofrac::scenario::Damping;
use hydrofrac::systems::solid::internal_force;
use hydrofrac::tet4::{self, TetGeometry};
use hydrofrac::tetmesh::TetMesh;
use hydrofrac::verify::solid3d_cases::{NU, YOUNG, params};
use hydrofrac::view::SolidView;

struct Tets {
    tets: Vec<[u32; 4]>,
    geo: Vec<TetGeometry>,
    u: Vec<[f64; 3]>,
    f: Vec<[f64; 3]>,
}

impl Tets {
    fn force(&mut self, p: &SolidParams) {
        self.f.iter_mut().for_each(|x| *x = [0.0; 3]);
        for (t, g) in self.tets.iter().zip(&self.geo) {
            let ue = t.map(|k| self.u[k as usize]);
            let fe = tet4::forces(g, tet4::hooke(tet4::strain(g, ue), p));
            for (a, &k) in t.iter().enumerate() {
                let fk = &mut self.f[k as usize];
                fk[0] += fe[a][0];
                fk[1] += fe[a][1];
                fk[2] += fe[a][2];
            }
        }
    }
}

struct Tris {
    tris: Vec<[u32; 3]>,
    geo: Vec<[f64; 7]>,
    u: Vec<[f64; 2]>,
    f: Vec<[f64; 2]>,
}

impl Tris {
    fn force(&mut self, p: &SolidParams) {
        self.f.iter_mut().for_each(|x| *x = [0.0; 2]);
        for (t, g) in self.tris.iter().zip(&self.geo) {
            let ue = t.map(|k| self.u[k as usize]);
            let fe = cst_forces(g, cst_stress(g, ue, p));
            for (a, &k) in t.iter().enumerate() {
                let fk = &mut self.f[k as usize];
                fk[0] += fe[2 * a];
                fk[1] += fe[2 * a + 1];
            }
        }
    }
}

fn tet4_force(c: &mut Criterion) {
    let mut group = c.benchmark_group("tet4_force");
    common::ten_samples(&mut group, 500, 2);
    let p = params(YOUNG, NU);
    for n in common::sizes("HYDROFRAC_BENCH_TETS", &[12, 24, 48]) {
        let h = 1.0 / n as f64;
        let m = TetMesh::regular_box([0.0; 3], [1.0; 3], h).unwrap();
        let elems = m.tets.len();
        let mut tets = Tets {
            geo: (0..elems)
                .map(|t| tet4::geometry(m.corners(t)).unwrap())
                .collect(),
            u: m.nodes.iter().map(|q| q.map(|x| 1e-4 * x * x)).collect(),
            f: vec![[0.0; 3]; m.nodes.len()],
            tets: m.tets,
        };
        // The CST on a square with about as many elements (2 per cell).
        let side = ((elems / 2) as f64).sqrt().round() as usize;
        let t2 = TriMesh::regular(1.0, 1.0, 1.0 / side as f64, [0.0, 0.0]).unwrap();
        let sp2 = SolidParams {
            damping: Damping::default(),
            ..p
        };
        let mut tris = Tris {
            geo: t2
                .triangles
                .iter()
                .map(|t| {
                    let g = hydrofrac::model::element_geometry(t.map(|k| t2.nodes[k as usize]));
                    [
                        g.area, g.dndx[0], g.dndx[1], g.dndx[2], g.dndy[0], g.dndy[1], g.dndy[2],
                    ]
                })
                .collect(),
            u: t2.nodes.iter().map(|q| q.map(|x| 1e-4 * x * x)).collect(),
            f: vec![[0.0; 2]; t2.nodes.len()],
            tris: t2.triangles.clone(),
        };
        group.throughput(Throughput::Elements(elems as u64));
        group.bench_function(BenchmarkId::new("tet4/1t", elems), |b| {
            b.iter(|| tets.force(&p))
        });
        group.throughput(Throughput::Elements(tris.tris.len() as u64));
        group.bench_function(BenchmarkId::new("cst/1t", tris.tris.len()), |b| {
            b.iter(|| tris.force(&sp2))
        });
        // The engine's system on the views of models built from the same meshes.
        let rock = hydrofrac::scenario::Material {
            young: YOUNG,
            poisson: NU,
            density: 2700.0,
        };
        let m3 = TetMesh::regular_box([0.0; 3], [1.0; 3], h).unwrap();
        let model3 = hydrofrac::model::Model::from_tet_mesh(&m3, rock).unwrap();
        let mut v3 = SolidView::<Tet4>::build_3d(&model3);
        v3.u.iter_mut()
            .zip(&v3.x0.clone())
            .for_each(|(u, x)| *u = x.map(|c| 1e-4 * c * c));
        let model2 = hydrofrac::model::Model::from_mesh(&t2, rock).unwrap();
        let mut v2 = SolidView::build(&model2);
        v2.u.iter_mut()
            .zip(&v2.x0.clone())
            .for_each(|(u, x)| *u = x.map(|c| 1e-4 * c * c));
        let one = common::pool(1);
        group.throughput(Throughput::Elements(v3.n_elems() as u64));
        group.bench_function(BenchmarkId::new("engine_tet4/1t", v3.n_elems()), |b| {
            one.install(|| b.iter(|| internal_force(&mut v3, &p)))
        });
        group.throughput(Throughput::Elements(v2.n_elems() as u64));
        group.bench_function(BenchmarkId::new("engine_cst/1t", v2.n_elems()), |b| {
            one.install(|| b.iter(|| internal_force(&mut v2, &p)))
        });
    }
    group.finish();
}

bench_main!(tet4_force);
