//! The 3D foundation (issue 38, first part): the TET4 element and the tetrahedral box meshes,
//! checked against closed forms before they enter the engine.
//! - the graded box mesh is a conforming, positively oriented cover of the box (volume, faces,
//!   Euler characteristic);
//! - the static patch test: a graded box under uniaxial stress, solved with faer's sparse
//!   Cholesky, reproduces the uniform stress and the linear displacement to round-off (TET4
//!   holds every linear field exactly, so any error above round-off is a defect);
//! - the explicit central-difference scheme with the lumped mass: the elements' critical step
//!   bounds the mesh's (Irons), within a factor of 2 of it; a run just below the mesh's step
//!   stays bounded and one just above it diverges;
//! - Sneddon's penny-shaped crack (`hydrofrac verify penny3d`) at a/h = 4 and 8, and the same
//!   crack with both faces opened by `TetMesh::split_along` (topology invariants asserted);
//! - 3D Gmsh import (`gmsh::parse_msh3`): tetrahedra with an embedded surface in both formats,
//!   and the bad meshes refused with the line and the reason;
//! - a manufactured smooth displacement (`hydrofrac verify mms3d`): second order.

use hydrofrac::verify::solid3d_cases::{
    NU, YOUNG, number_dofs, params, penny, solve, triangle_area,
};
use hydrofrac_core::tet4;
use hydrofrac_core::tetmesh::TetMesh;

const RHO: f64 = 2700.0;

fn graded() -> TetMesh {
    // 8 m x 6 m x 4 m, cells of 0.5 m around the centre growing by 1.4 per cell outwards,
    // refined 6 times towards the planes x = 4 m and z = 2 m (growing back by 1.5), and 3
    // times towards the box's side y = 0.
    use hydrofrac::scenario::{Axis, Refine};
    let r = |axis, at, factor| Refine {
        axis,
        at,
        factor,
        ratio: 1.5,
    };
    TetMesh::graded_box(
        [0.0, 0.0, 0.0],
        [8.0, 6.0, 4.0],
        0.5,
        [3.0, 2.0, 1.5, 5.0, 4.0, 2.5],
        1.4,
        &[
            r(Axis::X, 4.0, 6.0),
            r(Axis::Z, 2.0, 6.0),
            r(Axis::Y, 0.0, 3.0),
        ],
    )
    .expect("valid box")
}

#[test]
fn the_graded_box_is_a_conforming_cover() {
    let m = graded();
    let vol: f64 = (0..m.tets.len())
        .map(|t| {
            let g = tet4::geometry(m.corners(t)).expect("positive tetrahedron");
            g.volume
        })
        .sum();
    assert!((vol - 192.0).abs() < 1e-12 * 192.0, "volume {vol}");
    let faces = m.faces();
    // Every face has one or two tetrahedra; the boundary faces cover the box's surface.
    let mut area = 0.0;
    for (f, ts) in &faces {
        assert!(
            ts.len() == 1 || ts.len() == 2,
            "face {f:?} in {} tets",
            ts.len()
        );
        if ts.len() == 1 {
            let p = f.map(|n| m.nodes[n as usize]);
            area += triangle_area(p);
            // A boundary face lies on the box's surface.
            let on = |d: usize| {
                p.iter().all(|q| q[d].abs() < 1e-12)
                    || p.iter().all(|q| (q[d] - [8.0, 6.0, 4.0][d]).abs() < 1e-12)
            };
            assert!(on(0) || on(1) || on(2), "inner boundary face {p:?}");
        }
    }
    let surface = 2.0 * (8.0 * 6.0 + 8.0 * 4.0 + 6.0 * 4.0);
    assert!((area - surface).abs() < 1e-12 * surface, "surface {area}");
    // Euler characteristic of a ball: V - E + F - T = 1.
    let mut edges = std::collections::HashSet::new();
    for t in &m.tets {
        for a in 0..4 {
            for b in a + 1..4 {
                edges.insert((t[a].min(t[b]), t[a].max(t[b])));
            }
        }
    }
    let chi = m.nodes.len() as i64 - edges.len() as i64 + faces.len() as i64 - m.tets.len() as i64;
    assert_eq!(chi, 1);
    // Coordinate lines that do not increase are refused with the axis named.
    let e = TetMesh::tensor(&[0.0, 1.0], &[0.0, 0.0], &[0.0, 1.0]).expect_err("flat y");
    assert!(e.to_string().contains("mesh.y"), "{e}");
}

#[test]
fn a_graded_box_under_uniaxial_stress_is_exact() {
    // Symmetry planes x = 0, y = 0, z = 0 on rollers; a traction s on x = 8 m. The exact
    // solution is linear: u_x = s x / E, u_y = -nu s y / E, u_z = -nu s z / E, stress (s, 0, ...).
    let m = graded();
    let p = params(YOUNG, NU);
    let s = -5e6;
    let (dof, nf) = number_dofs(&m.nodes, |_, q, d| q[d].abs() < 1e-12);
    let mut rhs = faer::Col::<f64>::zeros(nf);
    for (f, ts) in m.faces() {
        let pts = f.map(|k| m.nodes[k as usize]);
        if ts.len() == 1 && pts.iter().all(|q| (q[0] - 8.0).abs() < 1e-12) {
            let area = triangle_area(pts);
            for k in f {
                rhs[dof[3 * k as usize]] += s * area / 3.0;
            }
        }
    }
    let u = solve(&m, &p, &dof, &rhs);
    let ue = |q: [f64; 3]| {
        [
            s * q[0] / YOUNG,
            -NU * s * q[1] / YOUNG,
            -NU * s * q[2] / YOUNG,
        ]
    };
    let disp = |i: usize| {
        let mut r = [0.0; 3];
        for d in 0..3 {
            if dof[3 * i + d] != usize::MAX {
                r[d] = u[dof[3 * i + d]];
            }
        }
        r
    };
    let umax = (s * 8.0 / YOUNG).abs();
    for (i, q) in m.nodes.iter().enumerate() {
        let (a, b) = (disp(i), ue(*q));
        for d in 0..3 {
            assert!(
                (a[d] - b[d]).abs() < 1e-9 * umax,
                "node {i} {q:?}: {a:?} against {b:?}"
            );
        }
    }
    for e in 0..m.tets.len() {
        let g = tet4::geometry(m.corners(e)).expect("valid");
        let ud = m.tets[e].map(|n| disp(n as usize));
        let st = tet4::hooke(tet4::strain(&g, ud), &p);
        let want = [s, 0.0, 0.0, 0.0, 0.0, 0.0];
        for c in 0..6 {
            assert!((st[c] - want[c]).abs() < 1e-8 * s.abs(), "tet {e}: {st:?}");
        }
    }
}

#[test]
fn the_explicit_step_is_bounded_by_the_elements_and_fails_just_above_the_mesh_s() {
    // A free 3 x 2 x 2 box of 0.5 m cubes: the mesh's omega_max by power iteration on
    // M^-1 K, the elements' exact bound beside it, and two central-difference runs.
    let m = TetMesh::regular_box([0.0; 3], [1.5, 1.0, 1.0], 0.5).expect("box");
    let p = params(YOUNG, NU);
    let n = m.nodes.len();
    let geo: Vec<_> = (0..m.tets.len())
        .map(|t| tet4::geometry(m.corners(t)).expect("valid"))
        .collect();
    let mut mass = vec![0.0; n];
    for (t, g) in m.tets.iter().zip(&geo) {
        for &k in t {
            mass[k as usize] += tet4::lumped_mass(g, RHO);
        }
    }
    let force = |u: &[[f64; 3]], f: &mut [[f64; 3]]| {
        f.iter_mut().for_each(|x| *x = [0.0; 3]);
        for (t, g) in m.tets.iter().zip(&geo) {
            let ue = t.map(|k| u[k as usize]);
            let fe = tet4::forces(g, tet4::hooke(tet4::strain(g, ue), &p));
            for (a, &k) in t.iter().enumerate() {
                for d in 0..3 {
                    f[k as usize][d] += fe[a][d];
                }
            }
        }
    };
    // Power iteration on M^-1 K (the rigid modes have omega = 0, the top mode dominates).
    let mut x: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let s = i as f64;
            [(s * 0.7).sin(), (s * 1.3).cos(), (s * 2.1).sin()]
        })
        .collect();
    let mut f = vec![[0.0; 3]; n];
    let mut lam = 0.0;
    for _ in 0..3000 {
        force(&x, &mut f);
        let y: Vec<[f64; 3]> = (0..n).map(|i| f[i].map(|v| -v / mass[i])).collect();
        let norm = y.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
        let xn = x.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
        lam = norm / xn;
        x = y.into_iter().map(|v| v.map(|c| c / norm)).collect();
    }
    let dt_mesh = 2.0 / lam.sqrt();
    let dt_elem = geo
        .iter()
        .map(|g| tet4::critical_step(g, &p, RHO))
        .fold(f64::INFINITY, f64::min);
    assert!(
        dt_elem <= dt_mesh * (1.0 + 1e-6),
        "element bound {dt_elem} above the mesh's {dt_mesh}"
    );
    assert!(
        dt_elem >= 0.5 * dt_mesh,
        "element bound {dt_elem} against {dt_mesh}"
    );
    // Central difference from the top mode's shape: bounded at 0.98 dt_mesh, growing at 1.02.
    let run = |dt: f64| {
        let mut u: Vec<[f64; 3]> = x.iter().map(|v| v.map(|c| 1e-6 * c)).collect();
        let mut v = vec![[0.0; 3]; n];
        let mut f = vec![[0.0; 3]; n];
        let amp0 = u.iter().flatten().fold(0.0f64, |a, c| a.max(c.abs()));
        let mut amp = amp0;
        for _ in 0..400 {
            force(&u, &mut f);
            for i in 0..n {
                for d in 0..3 {
                    v[i][d] += dt * f[i][d] / mass[i];
                    u[i][d] += dt * v[i][d];
                }
            }
            amp = u.iter().flatten().fold(0.0f64, |a, c| a.max(c.abs()));
        }
        amp / amp0
    };
    let below = run(0.98 * dt_mesh);
    let above = run(1.02 * dt_mesh);
    assert!(below < 10.0, "grew by {below} below the critical step");
    assert!(above > 1e3, "grew only by {above} above the critical step");
}

#[test]
fn the_penny_shaped_crack_opens_as_sneddon_s() {
    // Measured (2-core VM, `verify penny3d`): centre / volume / rms at a/h = 4: -6.5 /
    // -18.3 / 10.3 %; 8: -1.9 / -8.2 / 4.9 % (31k unknowns, 1.4 s); 16: -0.8 / -3.5 / 2.1 %
    // (113k, 19 s). The volume converges at about first order: the staircase front and the
    // linear elements' stiff tip. Tolerances: the measured errors at a/h = 8 with a margin of
    // a fifth, and the volume error falling by at least 1.8 from 4 to 8 (measured 2.2).
    let ([c4, v4, _], _) = penny(4.0);
    let ([c8, v8, rms8], _) = penny(8.0);
    assert!(
        c8.abs() < 0.025,
        "centre opening {:+.2} % at a/h = 8",
        100.0 * c8
    );
    assert!(
        v8.abs() < 0.10,
        "opened volume {:+.2} % at a/h = 8",
        100.0 * v8
    );
    assert!(rms8 < 0.06, "rms opening {:.2} % at a/h = 8", 100.0 * rms8);
    assert!(
        v8 < 0.0 && v4 < 0.0,
        "the staircase crack opens less: {v4}, {v8}"
    );
    assert!(v4 / v8 > 1.8, "volume error {v4} at a/h = 4, {v8} at 8");
    assert!(
        c4.abs() > c8.abs(),
        "centre error {c4} at a/h = 4, {c8} at 8"
    );
}

/// Element lines of [`box_msh`]: (tag, Gmsh type, 1-based node tags).
type Elems = Vec<(u64, u32, Vec<u32>)>;

/// A 2 x 1 x 1 box of unit cubes (12 tetrahedra) as Gmsh writes it, format 4.1 or 2.2: the
/// volume in the physical group "rock" and the interior square x = 1 (two triangles, faces of
/// the tetrahedra) in "fracture". `edit` changes the element lines (tag, type, nodes) first.
fn box_msh(v4: bool, edit: impl Fn(&mut Elems)) -> String {
    let m = TetMesh::regular_box([0.0; 3], [2.0, 1.0, 1.0], 1.0).expect("box");
    let mut elems: Elems = Vec::new();
    for (f, _) in m.faces() {
        if f.iter()
            .all(|&k| (m.nodes[k as usize][0] - 1.0).abs() < 1e-12)
        {
            elems.push((0, 2, f.iter().map(|k| k + 1).collect()));
        }
    }
    elems.sort();
    for t in &m.tets {
        elems.push((0, 4, t.iter().map(|k| k + 1).collect()));
    }
    for (i, e) in elems.iter_mut().enumerate() {
        e.0 = 100 + i as u64;
    }
    edit(&mut elems);
    let mut s = String::new();
    let nn = m.nodes.len();
    let ne = elems.len();
    let names = "$PhysicalNames\n2\n2 1 \"fracture\"\n3 2 \"rock\"\n$EndPhysicalNames\n";
    let list = |v: &[u32]| {
        v.iter()
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    if v4 {
        s += "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
        s += names;
        s += "$Entities\n0 0 1 1\n1 1 0 0 1 1 1 1 1 0\n1 0 0 0 2 1 1 1 2 0\n$EndEntities\n";
        s += &format!("$Nodes\n1 {nn} 1 {nn}\n3 1 0 {nn}\n");
        for i in 0..nn {
            s += &format!("{}\n", i + 1);
        }
        for q in &m.nodes {
            s += &format!("{} {} {}\n", q[0], q[1], q[2]);
        }
        s += "$EndNodes\n";
        let blocks: Vec<u32> = {
            let mut t: Vec<u32> = elems.iter().map(|e| e.1).collect();
            t.dedup();
            t
        };
        s += &format!("$Elements\n{} {ne} 100 {}\n", blocks.len(), 99 + ne);
        for ty in blocks {
            let of: Vec<_> = elems.iter().filter(|e| e.1 == ty).collect();
            let dim = if ty == 2 { 2 } else { 3 };
            s += &format!("{dim} 1 {ty} {}\n", of.len());
            for e in of {
                s += &format!("{} {}\n", e.0, list(&e.2));
            }
        }
        s += "$EndElements\n";
    } else {
        s += "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
        s += names;
        s += &format!("$Nodes\n{nn}\n");
        for (i, q) in m.nodes.iter().enumerate() {
            s += &format!("{} {} {} {}\n", i + 1, q[0], q[1], q[2]);
        }
        s += &format!("$EndNodes\n$Elements\n{ne}\n");
        for e in &elems {
            let phys = if e.1 == 2 { 1 } else { 2 };
            s += &format!("{} {} 2 {phys} 1 {}\n", e.0, e.1, list(&e.2));
        }
        s += "$EndElements\n";
    }
    s
}

#[test]
fn a_gmsh_tetrahedral_mesh_with_an_embedded_surface_is_read_in_both_formats() {
    use hydrofrac_core::gmsh::{parse_msh, parse_msh3};
    for v4 in [true, false] {
        let g = parse_msh3(&box_msh(v4, |_| {}), "box.msh").expect("valid 3D mesh");
        assert_eq!((g.mesh.nodes.len(), g.mesh.tets.len()), (12, 12));
        let vol: f64 = (0..12)
            .map(|t| tet4::geometry(g.mesh.corners(t)).expect("positive").volume)
            .sum();
        assert!((vol - 2.0).abs() < 1e-14, "volume {vol}");
        assert!(g.tet_physical.iter().all(|p| p.as_deref() == Some("rock")));
        assert_eq!(g.surfaces.len(), 2);
        assert!(
            g.surface_physical
                .iter()
                .all(|p| p.as_deref() == Some("fracture"))
        );
        for f in &g.surfaces {
            assert!(
                f.iter()
                    .all(|&k| (g.mesh.nodes[k as usize][0] - 1.0).abs() < 1e-12)
            );
        }
        assert_eq!(g.mesh.bbox, [0.0, 0.0, 0.0, 2.0, 1.0, 1.0]);
        // The 2D reader still refuses it as not planar.
        let e = parse_msh(&box_msh(v4, |_| {}), "box.msh").expect_err("3D file as 2D");
        assert!(e.to_string().contains("plane z = 0"), "{e}");
    }
    // Inverted tetrahedra are turned over; the file's order does not matter.
    let g = parse_msh3(
        &box_msh(true, |e| {
            for x in e.iter_mut().filter(|x| x.1 == 4) {
                x.2.swap(0, 1);
            }
        }),
        "box.msh",
    )
    .expect("inverted tetrahedra accepted");
    assert!((0..12).all(|t| tet4::geometry(g.mesh.corners(t)).is_some()));
    // From a file, and a missing file named.
    let dir = crate::support_cli::tmp_dir("msh3");
    std::fs::write(dir.join("box.msh"), box_msh(true, |_| {})).unwrap();
    let g = hydrofrac_core::gmsh::read_msh3(&dir.join("box.msh")).expect("read");
    assert_eq!(g.mesh.tets.len(), 12);
    let e = hydrofrac_core::gmsh::read_msh3(&dir.join("none.msh")).expect_err("missing");
    assert!(e.to_string().contains("none.msh: cannot read file"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_3d_gmsh_meshes_are_refused_with_the_line_and_the_reason() {
    use hydrofrac_core::gmsh::parse_msh3;
    let err = |v4: bool, edit: &dyn Fn(&mut Elems)| {
        parse_msh3(&box_msh(v4, edit), "box.msh")
            .expect_err("refused")
            .to_string()
    };
    // A degenerate tetrahedron (four coplanar nodes: the x = 1 square's corners).
    let e = err(false, &|e| {
        let t = e.iter_mut().find(|x| x.1 == 4).expect("a tet");
        t.2 = vec![2, 5, 8, 11];
    });
    assert!(
        e.contains("degenerate tetrahedron") && e.starts_with("box.msh:"),
        "{e}"
    );
    // A triangle that is not a face of the tetrahedra.
    let e = err(true, &|e| e[0].2 = vec![1, 2, 12]);
    assert!(
        e.contains("not a face of the tetrahedra") && e.contains("In Volume"),
        "{e}"
    );
    // Second-order tetrahedra and hexahedra: a hint.
    let e = err(false, &|e| {
        let t = e.iter_mut().find(|x| x.1 == 4).expect("a tet");
        t.1 = 11;
        t.2.extend([1, 2, 3, 4, 5, 6]);
    });
    assert!(e.contains("Mesh.ElementOrder = 1"), "{e}");
    let e = err(false, &|e| {
        let t = e.iter_mut().find(|x| x.1 == 4).expect("a tet");
        t.1 = 5;
        t.2 = (1..=8).collect();
    });
    assert!(e.contains("mesh the volume with tetrahedra"), "{e}");
    // No tetrahedra at all; a node that is not in $Nodes.
    let e = err(false, &|e| e.retain(|x| x.1 == 2));
    assert!(e.contains("no 4-node tetrahedra"), "{e}");
    let e = err(true, &|e| {
        let t = e.iter_mut().find(|x| x.1 == 4).expect("a tet");
        t.2[0] = 99;
    });
    assert!(e.contains("node 99, not in $Nodes"), "{e}");
}

/// The penny-shaped crack of [`penny`] with both faces: the box [0, 10a]^2 x [-10a, 10a]
/// (symmetric in x and y only), the crack opened by `TetMesh::split_along` on the grid's
/// triangles of z = 0 that touch a node inside r < a, the triangles whose centroid is inside
/// loaded by p on both faces. Returns the opened-volume error, the daughters, the crack's
/// inner nodes (r < a on z = 0) and the sister faces checked.
fn penny_split(cells_per_radius: f64) -> (f64, usize, usize) {
    let (a, p_crack) = (1.0, 1e6);
    let h = a / cells_per_radius;
    let len = 10.0 * a;
    let mut m = TetMesh::graded_box(
        [0.0, 0.0, -len],
        [len, len, 2.0 * len],
        h,
        [0.0, 0.0, -0.5, 1.5, 1.5, 0.5],
        1.25,
        &[],
    )
    .expect("box");
    let volume = |m: &TetMesh| -> f64 {
        (0..m.tets.len())
            .map(|t| tet4::geometry(m.corners(t)).expect("positive").volume)
            .sum()
    };
    let v_before = volume(&m);
    let r_of = |q: [f64; 3]| q[0].hypot(q[1]);
    let inner = |q: [f64; 3]| q[2].abs() < 1e-12 && r_of(q) < a - 1e-9;
    let n_inner = m.nodes.iter().filter(|q| inner(**q)).count();
    let crack: Vec<[u32; 3]> = m
        .faces()
        .into_iter()
        .filter(|(f, ts)| {
            ts.len() == 2
                && f.iter().all(|&k| m.nodes[k as usize][2].abs() < 1e-12)
                && f.iter().any(|&k| inner(m.nodes[k as usize]))
        })
        .map(|(f, _)| f)
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    let before = m.nodes.len();
    let split = m.split_along(&crack).expect("interior faces");
    // Topology: one copy per inner node, the volume unchanged, every tetrahedron valid, the
    // sisters at the same places on different nodes.
    assert_eq!(split.daughters.len(), n_inner);
    assert_eq!(m.nodes.len(), before + n_inner);
    let v_after = volume(&m);
    assert!((v_after - v_before).abs() < 1e-12 * v_before);
    for s in &split.sisters {
        for k in 0..3 {
            let (q0, q1) = (m.nodes[s[0][k] as usize], m.nodes[s[1][k] as usize]);
            assert_eq!(q0, q1, "sister nodes apart");
            // Inside the crack the sides hold different nodes; on its front the same one.
            assert_eq!(s[0][k] != s[1][k], inner(q0), "sister faces {s:?}");
        }
    }
    let p = params(YOUNG, NU);
    // Rollers on the symmetry planes x = 0, y = 0; the far faces held normally.
    let (dof, nf) = number_dofs(&m.nodes, |_, q, d| {
        if d < 2 {
            q[d].abs() < 1e-12 || (q[d] - len).abs() < 1e-12
        } else {
            (q[2].abs() - len).abs() < 1e-12
        }
    });
    let mut rhs = faer::Col::<f64>::zeros(nf);
    let all = m.faces();
    for s in &split.sisters {
        let pts = s[0].map(|k| m.nodes[k as usize]);
        let c = [
            (pts[0][0] + pts[1][0] + pts[2][0]) / 3.0,
            (pts[0][1] + pts[1][1] + pts[2][1]) / 3.0,
            0.0,
        ];
        if r_of(c) >= a {
            continue;
        }
        let area = triangle_area(pts);
        for side in s {
            let mut k = *side;
            k.sort_unstable();
            let t = all[&k][0] as usize;
            let zc: f64 = m.corners(t).iter().map(|q| q[2]).sum::<f64>() / 4.0;
            let sign = if zc > 0.0 { 1.0 } else { -1.0 };
            for node in side {
                let q = dof[3 * *node as usize + 2];
                if q != usize::MAX {
                    rhs[q] += sign * p_crack * area / 3.0;
                }
            }
        }
    }
    let u = solve(&m, &p, &dof, &rhs);
    let vol: f64 = (0..nf).map(|q| rhs[q] * u[q]).sum::<f64>() / p_crack;
    let v_want = 16.0 * (1.0 - NU * NU) * p_crack * a.powi(3) / (3.0 * YOUNG) / 4.0;
    (
        (vol - v_want) / v_want,
        split.daughters.len(),
        split.sisters.len(),
    )
}

#[test]
fn a_penny_crack_opened_by_node_splitting_matches_the_symmetric_model() {
    // Measured (2-core VM): opened volume -8.05 % split against -8.24 % symmetric at a/h = 8
    // (56 daughters, 112 sister faces, 6 s); at a/h = 4 (this test, 0.7 s) -17.6 against -18.3 %
    // (15 daughters, 30 sister faces). The two
    // models differ by the Kuhn split's lack of mirror symmetry about z = 0 and by the far
    // boundary (held normally at z = -10a instead of the symmetry plane), so the bound is a
    // point of the volume, not round-off.
    let (v_split, d, s) = penny_split(4.0);
    let ([_, v_sym, _], _) = penny(4.0);
    assert!(d > 0 && s > 0);
    assert!(
        (v_split - v_sym).abs() < 0.01,
        "split {v_split}, symmetric {v_sym}"
    );
    assert!(v_split.abs() < 0.22, "split volume error {v_split}");
    // A face on the domain's surface cannot be a fracture face.
    let mut m = TetMesh::regular_box([0.0; 3], [1.0; 3], 0.5).expect("box");
    let outer = *m
        .faces()
        .iter()
        .find(|(_, ts)| ts.len() == 1)
        .expect("a boundary face")
        .0;
    let e = m.split_along(&[outer]).expect_err("boundary face");
    assert!(e.to_string().contains("not an interior face"), "{e}");
}

#[test]
fn a_manufactured_smooth_displacement_converges_at_second_order() {
    // `verify mms3d --quick`: h = 1/4, 1/8, 1/16 (0.2 s); its order checks in [1.7, 2.3].
    let r = hydrofrac::verify::solid3d_cases::mms3d(true).expect("runs");
    assert!(r.passed(), "{:?}", r.failures());
    // And the error itself is small where it should be: below 1 % of the amplitude at 1/16.
    let (emax, _, _) = hydrofrac::verify::solid3d_cases::mms3d_level(16);
    assert!(emax < 0.01, "max nodal error {emax} of the amplitude");
}
