//! A corpus of bad inputs (README "Reliability", item 9): every case is a shipped scenario
//! with its text edited and/or `--set` overrides (or a file of its own), run through the binary
//! as a user would, in an empty working folder and with a wall-clock limit (a generator that
//! never ends fails the test instead of hanging it). Each must be refused quickly: a non-zero
//! exit that is not a panic (101), a first stderr line `error: ...` holding the expected text
//! (the field and the reason), and nothing created, neither in the working folder nor in the
//! output folder.

use crate::support_cli as cli;

use cli::{bin, root, tmp_dir};
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::{Duration, Instant};

/// One bad input.
struct Case {
    /// A shipped scenario (`scenarios/NAME`), or the text of a file of its own when it does not
    /// end in `.ron`.
    base: &'static str,
    /// Text replacements on the file (each must match).
    edits: &'static [(&'static str, &'static str)],
    /// Command line after `run FILE --out DIR --quiet` (`--set ...`, `--max-memory ...`).
    args: &'static [&'static str],
    /// Text the first error line must hold.
    expect: &'static [&'static str],
}

const fn set(
    base: &'static str,
    args: &'static [&'static str],
    expect: &'static [&'static str],
) -> Case {
    Case {
        base,
        edits: &[],
        args,
        expect,
    }
}

const fn edit(
    base: &'static str,
    edits: &'static [(&'static str, &'static str)],
    expect: &'static [&'static str],
) -> Case {
    Case {
        base,
        edits,
        args: &[],
        expect,
    }
}

const KGD: &str = "kgd.ron";
/// The in-situ scene's mesh, to replace by a Gmsh file.
const REGULAR: &str = "Regular(width: 100.0, height: 100.0, h: 1.0)";
const EX1: &str = "example1_cross.ron";
const INSITU: &str = "insitu_stress.ron";
const NET: &str = "flow_network.ron";
const JUNCTION: &str = "flow_junction.ron";
const SNEDDON: &str = "sneddon.ron";
/// A conforming mesh: Sneddon's crack at 30 degrees.
const INCLINED: &str = "inclined_crack.ron";

/// A small network scene for the cases that need a file of their own.
const SMALL: &str = r#"(
    name: "small",
    network: (fractures: [(from: (0.0, 0.0), to: (10.0, 0.0), aperture: 1e-4)], cell_length: 1.0),
    initial_fluid: Full(0.0),
    flow_boundaries: [(name: "in", at: Node((0.0, 0.0)), kind: Pressure(1e6))],
    time: (end: Time(0.01)),
)"#;

const CASES: &[Case] = &[
    // --- Files that cannot be read or parsed.
    edit("", &[], &["1:1"]),
    edit("(", &[], &["1:"]),
    edit("\u{0}\u{1}\u{2}garbage", &[], &["1:1"]),
    edit(SMALL, &[("name: \"small\",", "")], &["name"]),
    edit(
        SMALL,
        &[("cell_length: 1.0", "cell_length: 1.0, colour: 2")],
        &["colour"],
    ),
    edit(
        SMALL,
        &[("aperture: 1e-4", "aperture: \"wide\"")],
        &["aperture"],
    ),
    edit(
        SMALL,
        &[(
            "time: (end: Time(0.01)),\n)",
            "time: (end: Time(0.01)),\n) trailing",
        )],
        &["after the end"],
    ),
    edit(SMALL, &[("Time(0.01)", "Tim(0.01)")], &["Tim"]),
    edit(SMALL, &[("Pressure(1e6)", "Suction(1e6)")], &["Suction"]),
    // --- Run name.
    set(SMALL, &["--set", "name=\"../up\""], &["name", "--out"]),
    set(SMALL, &["--set", "name=\"\""], &["name", "empty"]),
    // --- --set and CLI options.
    set(SMALL, &["--set", "time.end"], &["--set", "PATH=VALUE"]),
    set(SMALL, &["--set", "time.colour=1"], &["--set", "colour"]),
    set(
        SMALL,
        &["--set", "time.safety=\"high\""],
        &["--set", "time.safety"],
    ),
    set(SMALL, &["--max-memory", "12GB"], &["--max-memory", "GB"]),
    set(
        SMALL,
        &["--max-memory=-1GiB"],
        &["--max-memory", "at least one byte"],
    ),
    set(SMALL, &["--disable", "warp_drive"], &["warp_drive"]),
    // --- Mesh.
    set(INSITU, &["--set", "mesh.h=0"], &["mesh.h", "> 0"]),
    set(INSITU, &["--set", "mesh.h=-1"], &["mesh.h", "> 0"]),
    set(
        INSITU,
        &["--set", "mesh.h=3"],
        &["mesh.width", "whole number"],
    ),
    set(
        INSITU,
        &["--set", "mesh.h=200"],
        &["mesh.h", "smaller than the domain"],
    ),
    set(INSITU, &["--set", "mesh.width=0"], &["mesh.width", "> 0"]),
    set(
        INSITU,
        &["--set", "mesh.height=-100"],
        &["mesh.height", "> 0"],
    ),
    edit(INSITU, &[("h: 1.0)", "h: NaN)")], &["mesh.h", "finite"]),
    edit(
        INSITU,
        &[("width: 100.0", "width: inf")],
        &["mesh.width", "finite"],
    ),
    edit(
        INSITU,
        &[("h: 1.0)", "h: 1.0, origin: (NaN, 0.0))")],
        &["mesh.origin", "finite"],
    ),
    edit(
        INSITU,
        &[("h: 1.0)", "h: 1.0, origin: (1e308, 0.0))")],
        &["mesh.origin", "double precision"],
    ),
    set(
        INSITU,
        &["--set", "mesh.h=0.002"],
        &["mesh.h", "triangles", "limit"],
    ),
    set(
        INSITU,
        &["--set", "mesh.h=0.1", "--max-memory", "100MiB"],
        &["mesh.h", "estimated", "100.0 MiB", "--max-memory"],
    ),
    set(
        INSITU,
        &[
            "--set",
            "mesh.h=0.5",
            "--set",
            "time.solid_scheme=\"QuasiStatic\"",
            "--max-memory",
            "64MiB",
        ],
        &["mesh.h", "estimated", "--max-memory"],
    ),
    set(
        KGD,
        &["--set", "mesh.ratio=0.5"],
        &["mesh.ratio", "[1, 10]"],
    ),
    set(KGD, &["--set", "mesh.ratio=0"], &["mesh.ratio", "[1, 10]"]),
    set(KGD, &["--set", "mesh.ratio=-2"], &["mesh.ratio", "[1, 10]"]),
    set(
        KGD,
        &["--set", "mesh.ratio=1e6"],
        &["mesh.ratio", "[1, 10]"],
    ),
    edit(
        KGD,
        &[("ratio: 1.2", "ratio: NaN")],
        &["mesh.ratio", "finite"],
    ),
    edit(
        KGD,
        &[("ratio: 1.2", "ratio: inf")],
        &["mesh.ratio", "finite"],
    ),
    set(
        KGD,
        &["--set", "mesh.fine=[40, -2, 0, 2]"],
        &["mesh.fine", "x0 < x1"],
    ),
    set(
        KGD,
        &["--set", "mesh.fine=[0, -2, 400, 2]"],
        &["mesh.fine", "inside the domain"],
    ),
    edit(
        KGD,
        &[(
            "fine: (0.0, -2.0, 40.0, 2.0)",
            "fine: (0.0, NaN, 40.0, 2.0)",
        )],
        &["mesh.fine", "finite"],
    ),
    set(
        KGD,
        &["--set", "mesh.fine=[0, -2, 40.5, 2]"],
        &["mesh.fine width", "whole number"],
    ),
    // Conforming meshes (`scenarios/inclined_crack.ron`).
    set(
        INCLINED,
        &["--set", "mesh.grading=0"],
        &["mesh.grading", "[0.01, 2]"],
    ),
    set(
        INCLINED,
        &["--set", "mesh.grading=5"],
        &["mesh.grading", "[0.01, 2]"],
    ),
    edit(
        INCLINED,
        &[("h_far: 2.0)", "h_far: 2.0, grading: NaN)")],
        &["mesh.grading", "finite"],
    ),
    edit(
        INCLINED,
        &[("h_far: 2.0)", "h_far: 0.01)")],
        &["mesh.h_far", "between h"],
    ),
    edit(
        INCLINED,
        &[("h_far: 2.0)", "h_far: 400.0)")],
        &["mesh.h_far", "between h"],
    ),
    edit(
        INCLINED,
        &[("h_far: 2.0)", "h_far: inf)")],
        &["mesh.h_far", "finite"],
    ),
    set(
        INCLINED,
        &["--set", "mesh.min_angle_deg=40"],
        &["mesh.min_angle_deg", "(0, 33]"],
    ),
    set(
        INCLINED,
        &["--set", "mesh.min_angle_deg=0"],
        &["mesh.min_angle_deg", "(0, 33]"],
    ),
    set(
        INCLINED,
        &["--set", "mesh.merge=0.9"],
        &["mesh.merge", "[0, 0.5]"],
    ),
    set(
        INCLINED,
        &["--set", "mesh.merge=-0.1"],
        &["mesh.merge", "[0, 0.5]"],
    ),
    edit(
        INCLINED,
        &[(
            "h_far: 2.0)",
            "h_far: 2.0, follow: [(from: (0.0, 0.0), to: (1.0, 1.0)), (from: (0.0, 0.0), to: (NaN, 1.0))])",
        )],
        &["mesh.follow[1]", "finite"],
    ),
    // The conforming mesh is fine only near its crack (h = 1 mm is 3e5 triangles, a valid
    // run since the estimate follows the sizing field); 1 um is 2.8e8.
    set(
        INCLINED,
        &["--set", "mesh.h=1e-6"],
        &["mesh.h", "triangles", "limit"],
    ),
    set(KGD, &["--set", "mesh.h=0.001"], &["mesh.h", "5e7"]),
    set(SNEDDON, &["--set", "mesh.h=0.0001"], &["mesh.h", "5e7"]),
    edit(
        INSITU,
        &[(
            "Regular(width: 100.0, height: 100.0, h: 1.0)",
            "Perturbed(width: 100.0, height: 100.0, h: 1.0, fraction: 0.5, seed: 1)",
        )],
        &["mesh.fraction", "[0, 0.3]"],
    ),
    edit(
        INSITU,
        &[(
            "Regular(width: 100.0, height: 100.0, h: 1.0)",
            "Perturbed(width: 100.0, height: 100.0, h: 1.0, fraction: NaN, seed: 1)",
        )],
        &["mesh.fraction", "finite"],
    ),
    edit(
        INSITU,
        &[(
            "Regular(width: 100.0, height: 100.0, h: 1.0)",
            "Gmsh(file: \"no_such_mesh.msh\")",
        )],
        &["mesh.file"],
    ),
    edit(
        INSITU,
        &[(REGULAR, "Gmsh(file: \"empty.msh\")")],
        &["mesh.file", "empty file"],
    ),
    edit(
        INSITU,
        &[(REGULAR, "Gmsh(file: \"garbage.msh\")")],
        &["mesh.file", "$MeshFormat"],
    ),
    edit(
        INSITU,
        &[(REGULAR, "Gmsh(file: \"bad_ref.msh\")")],
        &["mesh.file", "refers to node 9"],
    ),
    edit(
        INSITU,
        &[(REGULAR, "Gmsh(file: \"no_triangles.msh\")")],
        &["mesh.file", "no 3-node triangles"],
    ),
    edit(
        INSITU,
        &[(REGULAR, "Gmsh(file: \"flat.msh\")")],
        &["mesh.file", "degenerate triangle"],
    ),
    edit(
        INSITU,
        &[(REGULAR, "Gmsh(file: \"nan.msh\")")],
        &["mesh.file", "non-finite coordinate"],
    ),
    edit(
        INSITU,
        &[(REGULAR, "Gmsh(file: \"short.msh\")")],
        &["mesh.file", "fewer entries than declared"],
    ),
    edit(
        INSITU,
        &[(REGULAR, "Gmsh(file: \"folder.msh\")")],
        &["mesh.file", "cannot read"],
    ),
    // --- Material.
    set(
        INSITU,
        &["--set", "material.young=0"],
        &["material.young", "> 0"],
    ),
    set(
        INSITU,
        &["--set", "material.young=-2e10"],
        &["material.young", "> 0"],
    ),
    edit(
        INSITU,
        &[("young: 20e9", "young: NaN")],
        &["material.young", "finite"],
    ),
    set(
        INSITU,
        &["--set", "material.poisson=0.5"],
        &["material.poisson", "[0, 0.5)"],
    ),
    set(
        INSITU,
        &["--set", "material.poisson=-0.1"],
        &["material.poisson", "[0, 0.5)"],
    ),
    // A coupled run (Example I: a pump into the rock's fractures) with nearly incompressible
    // rock: the seed's fluid volume does not bound its pressure (README "Reliability"). In the
    // file and by --set; the same nu without flow is accepted (`dry in-situ nu 0.499` of
    // `verify extreme`).
    set(
        EX1,
        &["--set", "material.poisson=0.499"],
        &[
            "material.poisson",
            "0.499 is above 0.48 for a coupled run",
            "L max(delta_n, a_r)",
            "use material.poisson <= 0.48",
        ],
    ),
    edit(
        EX1,
        &[("poisson: 0.2", "poisson: 0.49")],
        &["material.poisson", "0.49 is above 0.48", "p_max"],
    ),
    set(
        INSITU,
        &["--set", "material.density=0"],
        &["material.density", "> 0"],
    ),
    set(
        INSITU,
        &["--set", "material.density=1e-300"],
        &["material.density", "critical step"],
    ),
    edit(
        INSITU,
        &[("density: 2700.0", "density: inf")],
        &["material.density", "finite"],
    ),
    edit(
        INSITU,
        &[(
            "    material: (young: 20e9, poisson: 0.2, density: 2700.0),\n",
            "",
        )],
        &["material", "needs a material"],
    ),
    // --- Boundary, pins, gravity, schedules.
    edit(
        INSITU,
        &[("sxx: -20e6", "sxx: NaN")],
        &["boundary.sxx", "finite"],
    ),
    edit(
        SNEDDON,
        &[("left: Fixed", "left: Normal(inf)")],
        &["boundary.left", "finite"],
    ),
    edit(
        SNEDDON,
        &[("top: Fixed", "top: Traction(normal: NaN, shear: 0.0)")],
        &["boundary.top.normal", "finite"],
    ),
    set(
        INSITU,
        &[
            "--set",
            "initial_state=\"InSitu\"",
            "--set",
            "boundary={\"Sides\":{}}",
        ],
        &["initial_state", "InSitu"],
    ),
    set(
        INSITU,
        &["--set", "pins=[{\"at\":[0,0]}]"],
        &["pins[0]", "none of ux, uy, uz"],
    ),
    edit(
        INSITU,
        &[(
            "damping: Local(0.8),",
            "damping: Local(0.8), pins: [(at: (NaN, 0.0), ux: Some(0.0))],",
        )],
        &["pins[0]", "finite"],
    ),
    edit(
        INSITU,
        &[(
            "damping: Local(0.8),",
            "damping: Local(0.8), gravity: Some((0.0, NaN)),",
        )],
        &["gravity", "finite"],
    ),
    set(
        INSITU,
        &["--set", "boundary_schedule=[[1, 1], [0, 0]]"],
        &["boundary_schedule[1]", "decrease"],
    ),
    edit(
        INSITU,
        &[(
            "damping: Local(0.8),",
            "damping: Local(0.8), boundary_schedule: [(0.0, NaN)],",
        )],
        &["boundary_schedule", "finite"],
    ),
    // --- Time.
    set(
        INSITU,
        &["--set", "time.safety=0"],
        &["time.safety", "(0, 1]"],
    ),
    set(
        INSITU,
        &["--set", "time.safety=1.5"],
        &["time.safety", "(0, 1]"],
    ),
    set(INSITU, &["--set", "time.dt=0"], &["time.dt", "> 0"]),
    set(INSITU, &["--set", "time.dt=-1e-5"], &["time.dt", "> 0"]),
    set(
        INSITU,
        &["--set", "time.dt=1e-320"],
        &["time.dt", "too small to represent"],
    ),
    set(
        SMALL,
        &["--set", "time.flow_dt=0"],
        &["time.flow_dt", "> 0"],
    ),
    set(
        INSITU,
        &["--set", "time.max_steps=0"],
        &["time.max_steps", "at least 1"],
    ),
    set(
        INSITU,
        &["--set", "time.max_steps=5"],
        &["time.end.min_steps", "time.max_steps = 5"],
    ),
    set(
        INSITU,
        &["--set", "time.end={\"Static\":{\"tol\":0}}"],
        &["time.end.tol", "> 0"],
    ),
    set(
        INSITU,
        &[
            "--set",
            "time.end={\"Static\":{\"tol\":1e-9,\"min_steps\":100}}",
            "--set",
            "time.max_steps=50",
        ],
        &["time.end.min_steps"],
    ),
    set(SMALL, &["--set", "time.end=Time(0)"], &["time.end", "> 0"]),
    set(SMALL, &["--set", "time.end=Time(-1)"], &["time.end", "> 0"]),
    edit(
        SMALL,
        &[("Time(0.01)", "Time(NaN)")],
        &["time.end", "finite"],
    ),
    set(
        INSITU,
        &[
            "--set",
            "time.mass_scaling=true",
            "--set",
            "time.end=Time(1)",
        ],
        &["time.mass_scaling", "static"],
    ),
    set(
        INSITU,
        &["--set", "time.selective_mass_scaling=Some(0.5)"],
        &["time.selective_mass_scaling", "at least 1"],
    ),
    set(
        INSITU,
        &["--set", "time.selective_mass_scaling=Some(inf)"],
        &["time.selective_mass_scaling", "expected f64"],
    ),
    set(
        INSITU,
        &[
            "--set",
            "time.selective_mass_scaling=Some(4)",
            "--set",
            "time.solid_scheme=\"QuasiStatic\"",
        ],
        &["time.selective_mass_scaling", "quasi-static"],
    ),
    set(
        SMALL,
        &["--set", "time.solid_scheme=\"QuasiStatic\""],
        &["time.solid_scheme", "mesh"],
    ),
    set(
        INSITU,
        &["--set", "time.end=\"SteadyDirect\""],
        &["time.end", "SteadyDirect"],
    ),
    set(
        KGD,
        &["--set", "time.max_substeps=0"],
        &["time.max_substeps", ">= 1"],
    ),
    set(
        KGD,
        &["--set", "time.max_resolves=0"],
        &["time.max_resolves", ">= 1"],
    ),
    set(KGD, &["--set", "time.dt_max=0"], &["time.dt_max", "> 0"]),
    set(
        KGD,
        &["--set", "time.dt_min=1", "--set", "time.dt_max=0.1"],
        &["time.dt_min", "time.dt_max"],
    ),
    set(
        KGD,
        &["--set", "time.flow_dt=1e-3"],
        &["time.flow_dt", "implicit"],
    ),
    // --- Damping.
    set(
        INSITU,
        &["--set", "damping=Local(1.0)"],
        &["damping", "[0, 1)"],
    ),
    set(
        INSITU,
        &["--set", "damping=Local(-0.1)"],
        &["damping", "[0, 1)"],
    ),
    set(
        INSITU,
        &["--set", "damping=Viscous(-1)"],
        &["damping", ">= 0"],
    ),
    edit(
        INSITU,
        &[("damping: Local(0.8)", "damping: Viscous(NaN)")],
        &["damping", "finite"],
    ),
    // --- Fracture.
    edit(
        EX1,
        &[(
            "strength: Some(1e6),",
            "strength: Some(1e6), criterion: Some(Toughness(k_ic: 1e6)),",
        )],
        &["fracture.criterion", "not both"],
    ),
    edit(
        EX1,
        &[(
            "strength: Some(1e6),",
            "criterion: Some(Toughness(k_ic: -1e6)),",
        )],
        &["fracture.criterion.k_ic", ">= 0"],
    ),
    edit(
        EX1,
        &[(
            "strength: Some(1e6),",
            "criterion: Some(Toughness(k_ic: NaN)),",
        )],
        &["fracture.criterion.k_ic", "finite"],
    ),
    edit(
        EX1,
        &[(
            "strength: Some(1e6),",
            "criterion: Some(Toughness(k_ic: 1e6, initiation: Some(inf))),",
        )],
        &["fracture.criterion.initiation", "finite"],
    ),
    edit(
        EX1,
        &[(
            "strength: Some(1e6),",
            "criterion: Some(Toughness(kic: 1e6)),",
        )],
        &["kic"],
    ),
    set(
        EX1,
        &["--set", "fracture.friction_deg=-1"],
        &["fracture.friction_deg", "[0, 90)"],
    ),
    set(
        EX1,
        &["--set", "fracture.friction_deg=90"],
        &["fracture.friction_deg", "[0, 90)"],
    ),
    edit(
        EX1,
        &[("friction_deg: 45.0", "friction_deg: NaN")],
        &["fracture.friction_deg", "finite"],
    ),
    set(
        EX1,
        &["--set", "fracture.normal_stiffness=-1"],
        &["fracture.normal_stiffness", "> 0"],
    ),
    set(
        EX1,
        &["--set", "fracture.shear_stiffness=0"],
        &["fracture.shear_stiffness", "> 0"],
    ),
    edit(
        EX1,
        &[("shear_stiffness: Some(8.3e9)", "shear_stiffness: Some(NaN)")],
        &["fracture.shear_stiffness", "finite"],
    ),
    set(
        EX1,
        &["--set", "fracture.residual_aperture=0"],
        &["fracture.residual_aperture", "> 0"],
    ),
    edit(
        EX1,
        &[("strength: Some(1e6)", "strength: Some(inf)")],
        &["fracture.strength", "finite"],
    ),
    edit(
        EX1,
        &[(
            "(from: (16.0, 46.0), to: (16.0, 54.0))",
            "(from: (16.0, NaN), to: (16.0, 54.0))",
        )],
        &["fracture.preexisting[1]", "finite"],
    ),
    edit(
        EX1,
        &[(
            "(from: (16.0, 46.0), to: (16.0, 54.0))",
            "(from: (200.0, 46.0), to: (200.0, 54.0))",
        )],
        &["fracture.preexisting[1]", "outside the domain"],
    ),
    edit(
        EX1,
        &[(
            "(from: (16.0, 46.0), to: (16.0, 54.0))",
            "(from: (16.0, 46.0), to: (16.1, 46.1))",
        )],
        &["fracture.preexisting[1]", "shorter than one mesh edge"],
    ),
    set(
        EX1,
        &[
            "--set",
            "fracture.preexisting=[{\"from\":[0,0],\"to\":[100,0]}]",
        ],
        &["fracture.preexisting[0]", "domain boundary", "cannot open"],
    ),
    set(
        INSITU,
        &["--set", "pins=[{\"at\":[500,500],\"ux\":0}]"],
        &["pins[0].at", "from the nearest node"],
    ),
    edit(
        INSITU,
        &[(
            "systems: (disable: [])",
            "systems: (disable: [\"warp_drive\"])",
        )],
        &["unknown system `warp_drive`"],
    ),
    edit(
        SNEDDON,
        &[("pressure: 1e6", "pressure: NaN")],
        &["fracture.pressure", "finite"],
    ),
    set(
        SMALL,
        &["--set", "fracture={\"strength\":1e6}"],
        &["fracture", "mesh"],
    ),
    // --- Output.
    set(
        SMALL,
        &["--set", "output.series_every=0"],
        &["output.series_every", "at least 1"],
    ),
    set(
        EX1,
        &["--set", "output.figure_times=[-1]"],
        &["output.figure_times[0]", ">= 0"],
    ),
    edit(
        EX1,
        &[("figure_times: [0.45, 0.8]", "figure_times: [0.45, NaN]")],
        &["output.figure_times[1]", "finite"],
    ),
    // --- Network.
    set(
        JUNCTION,
        &["--set", "network.cell_length=0"],
        &["network.cell_length", "> 0"],
    ),
    set(
        JUNCTION,
        &["--set", "network.cell_length=1e-9"],
        &["network.cell_length", "estimated", "cells"],
    ),
    edit(
        JUNCTION,
        &[("cell_length: 0.5", "cell_length: NaN")],
        &["network.cell_length", "finite number > 0, got NaN"],
    ),
    edit(
        JUNCTION,
        &[("aperture: 2e-4", "aperture: -2e-4")],
        &["network.fractures[0].aperture", "> 0"],
    ),
    edit(
        JUNCTION,
        &[("aperture: 2e-4", "aperture: inf")],
        &[
            "network.fractures[0].aperture",
            "finite number > 0, got inf",
        ],
    ),
    edit(
        JUNCTION,
        &[("to: (10.0, 0.0), aperture", "to: (inf, 0.0), aperture")],
        &["network.fractures[0]", "finite"],
    ),
    edit(
        JUNCTION,
        &[("to: (10.0, 0.0), aperture", "to: (0.0, 0.0), aperture")],
        &["network.fractures[0]", "zero length"],
    ),
    set(
        JUNCTION,
        &["--set", "network.fractures=[]"],
        &["network", "no fractures"],
    ),
    set(
        NET,
        &["--set", "network.random.count=1000000000"],
        &["network.random.count", "1.000e9 fractures"],
    ),
    set(
        NET,
        &[
            "--set",
            "network.random.count=50000",
            "--max-memory",
            "1GiB",
        ],
        &["network.cell_length", "estimated", "1.00 GiB"],
    ),
    edit(
        NET,
        &[("count: 40", "count: 1000000000000000000")],
        &["network.random.count", "fractures"],
    ),
    set(
        NET,
        &["--set", "network.random.angles_deg=[]"],
        &["network.random.angles_deg", "family"],
    ),
    edit(
        NET,
        &[("angles_deg: [20.0, 110.0]", "angles_deg: [20.0, NaN]")],
        &["network.random.angles_deg", "finite"],
    ),
    edit(
        NET,
        &[("size: (30.0, 20.0)", "size: (inf, 20.0)")],
        &["network.random.size", "finite"],
    ),
    set(
        NET,
        &["--set", "network.random.size=[0, 20]"],
        &["network.random.size", "positive"],
    ),
    edit(
        NET,
        &[
            ("size: (30.0, 20.0)", "size: (1e308, 20.0)"),
            ("origin: (0.0, 0.0)", "origin: (1e308, 0.0)"),
        ],
        &["network.random.size", "finite"],
    ),
    edit(
        NET,
        &[("origin: (0.0, 0.0)", "origin: (NaN, 0.0)")],
        &["network.random.origin", "finite"],
    ),
    edit(
        NET,
        &[("length: (4.0, 14.0)", "length: (4.0, inf)")],
        &["network.random.length", "finite"],
    ),
    set(
        NET,
        &["--set", "network.random.length=[14, 4]"],
        &["network.random.length", "min <= max"],
    ),
    set(
        NET,
        &["--set", "network.random.length=[0, 4]"],
        &["network.random.length", "min <= max"],
    ),
    edit(
        NET,
        &[("aperture: (5e-5, 3e-4)", "aperture: (5e-5, inf)")],
        &["network.random.aperture", "finite"],
    ),
    set(
        NET,
        &["--set", "network.random.aperture=[0, 3e-4]"],
        &["network.random.aperture", "min <= max"],
    ),
    edit(
        NET,
        &[("jitter_deg: 15.0", "jitter_deg: inf")],
        &["network.random.jitter_deg", "finite"],
    ),
    edit(
        NET,
        &[("jitter_deg: 15.0", "jitter_deg: NaN")],
        &["network.random.jitter_deg", "finite"],
    ),
    set(
        NET,
        &["--set", "network.random.jitter_deg=-5"],
        &["network.random.jitter_deg", "[0, 90]"],
    ),
    set(
        INSITU,
        &[
            "--set",
            "network={\"fractures\":[{\"from\":[0,0],\"to\":[1,0],\"aperture\":1e-4}],\"cell_length\":0.5}",
        ],
        &["network", "mesh"],
    ),
    // --- Fluid and flow boundaries.
    set(
        SMALL,
        &["--set", "fluid.viscosity=0"],
        &["fluid.viscosity", "> 0"],
    ),
    set(
        SMALL,
        &["--set", "fluid.bulk_modulus=-1"],
        &["fluid.bulk_modulus", "> 0"],
    ),
    edit(
        SMALL,
        &[(
            "initial_fluid: Full(0.0)",
            "initial_fluid: Full(0.0), fluid: (density: NaN)",
        )],
        &["fluid.density", "finite"],
    ),
    set(
        SMALL,
        &["--set", "initial_fluid=Full(-1)"],
        &["initial_fluid", ">= 0"],
    ),
    edit(
        SMALL,
        &[("Full(0.0)", "Full(inf)")],
        &["initial_fluid", "finite"],
    ),
    edit(
        SMALL,
        &[("Pressure(1e6)", "Pressure(NaN)")],
        &["flow_boundaries[0].kind", "finite"],
    ),
    edit(
        SMALL,
        &[("Pressure(1e6)", "Pump(p_max: -1.0, q_half: 1.0)")],
        &["flow_boundaries[0].kind.p_max", "> 0"],
    ),
    edit(
        SMALL,
        &[("Pressure(1e6)", "Pump(p_max: 1e6, q_half: 0.0)")],
        &["flow_boundaries[0].kind.q_half", "> 0"],
    ),
    edit(
        SMALL,
        &[("Node((0.0, 0.0))", "Node((NaN, 0.0))")],
        &["flow_boundaries[0].at", "finite"],
    ),
    edit(
        SMALL,
        &[("Node((0.0, 0.0))", "Node((0.0, 50.0))")],
        &["flow_boundaries[0].at", "on the network"],
    ),
    edit(
        SMALL,
        &[(
            "kind: Pressure(1e6))",
            "kind: Pressure(1e6), schedule: [(1.0, 1.0), (0.5, 0.0)])",
        )],
        &["flow_boundaries[0].schedule[1]", "decrease"],
    ),
    edit(
        SMALL,
        &[(
            "kind: Pressure(1e6))",
            "kind: Pressure(1e6), schedule: [(0.0, inf)])",
        )],
        &["flow_boundaries[0].schedule", "finite"],
    ),
    edit(
        SMALL,
        &[(
            "kind: Pressure(1e6))]",
            "kind: Pressure(1e6)), (name: \"in\", at: Node((10.0, 0.0)), kind: Pressure(0.0))]",
        )],
        &["flow_boundaries[1].name", "\"in\""],
    ),
    edit(
        SMALL,
        &[(
            "kind: Pressure(1e6))]",
            "kind: Pressure(1e6)), (at: Node((10.0, 0.0)), kind: Pressure(0.0)), (name: \"bc1\", at: Node((5.0, 0.0)), kind: Pressure(0.0))]",
        )],
        &["flow_boundaries[2].name", "\"bc1\""],
    ),
    edit(
        SMALL,
        &[(
            "kind: Pressure(1e6))]",
            "kind: Pressure(1e6)), (name: \"b\", at: Node((0.1, 0.0)), kind: Rate(1e-6))]",
        )],
        &["flow_boundaries[1].at", "flow_boundaries[0]", "one node"],
    ),
    edit(
        SMALL,
        &[(
            "kind: Pressure(1e6))]",
            "kind: Pressure(1e6)), (name: \"b\", at: Cell((4.5, 0.0)), kind: Rate(1e-6)), (name: \"c\", at: Cell((4.6, 0.0)), kind: Rate(1e-6))]",
        )],
        &["flow_boundaries[2].at", "one cell"],
    ),
    set(
        SMALL,
        &[
            "--set",
            "time.end=\"SteadyDirect\"",
            "--set",
            "flow_boundaries=[{\"at\":{\"Node\":[0,0]},\"kind\":{\"Pump\":{\"p_max\":1e6,\"q_half\":1}}}]",
        ],
        &["flow_boundaries[0].kind", "pump"],
    ),
    set(
        INSITU,
        &[
            "--set",
            "flow_boundaries=[{\"at\":{\"Node\":[0,0]},\"kind\":{\"Rate\":1e-3}}]",
        ],
        &["flow_boundaries", "no fracture network"],
    ),
    // --- A non-finite number of the file with an unrelated `--set`: the file is named, not
    // the override (JSON, which the overrides go through, has no NaN).
    Case {
        base: KGD,
        edits: &[("ratio: 1.2", "ratio: NaN")],
        args: &["--set", "time.max_steps=1"],
        expect: &["invalid mesh.ratio", "NaN or inf in the scenario file"],
    },
    Case {
        base: EX1,
        edits: &[("young: 20e9", "young: inf")],
        args: &["--set", "damping=None", "--set", "output.series_every=5"],
        expect: &["invalid material.young", "NaN or inf in the scenario file"],
    },
    Case {
        base: NET,
        edits: &[("jitter_deg: 15.0", "jitter_deg: NaN")],
        args: &["--set", "network.cell_length=1.0"],
        expect: &["invalid network.random.jitter_deg", "scenario file"],
    },
    // --- Not a scene.
    set(
        SMALL,
        &["--set", "network=null"],
        &["mesh", "a mesh, a network"],
    ),
];

/// Bad Gmsh files, written beside the scenarios (a mesh path is relative to the scenario).
const MESH_FILES: &[(&str, &str)] = &[
    ("empty.msh", ""),
    ("garbage.msh", "\u{7f}ELF\u{0}\u{1}binary garbage\n"),
    (
        "bad_ref.msh",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n\
         $Elements\n1\n1 2 2 0 1 1 2 9\n$EndElements\n",
    ),
    (
        "no_triangles.msh",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n\
         $Elements\n0\n$EndElements\n",
    ),
    (
        "flat.msh",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 2 0 0\n$EndNodes\n\
         $Elements\n1\n1 2 2 0 1 1 2 3\n$EndElements\n",
    ),
    (
        "nan.msh",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 NaN 1 0\n$EndNodes\n\
         $Elements\n1\n1 2 2 0 1 1 2 3\n$EndElements\n",
    ),
    (
        "short.msh",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n99999999999\n1 0 0 0\n$EndNodes\n",
    ),
];

/// The case's scenario file, written into `dir`.
fn scenario_file(case: &Case, k: usize, dir: &Path) -> PathBuf {
    let mut text = if case.base.ends_with(".ron") {
        std::fs::read_to_string(root().join("scenarios").join(case.base)).unwrap()
    } else {
        case.base.to_string()
    };
    for (from, to) in case.edits {
        assert!(
            text.contains(from),
            "case {k}: `{from}` not in {}",
            case.base
        );
        text = text.replacen(from, to, 1);
    }
    let path = dir.join(format!("case{k}.ron"));
    std::fs::write(&path, text).unwrap();
    path
}

/// Every case is refused in well under the limit, without a panic, with its text in the first
/// error line, and nothing is created in the working folder or the output folder.
#[test]
fn every_bad_input_is_refused_with_a_clear_message() {
    let files = tmp_dir("files");
    for (name, text) in MESH_FILES {
        std::fs::write(files.join(name), text).unwrap();
    }
    std::fs::create_dir_all(files.join("folder.msh")).unwrap();
    let cwd = tmp_dir("cwd");
    let limit = Duration::from_secs(30);
    let mut failures = Vec::new();
    for (k, case) in CASES.iter().enumerate() {
        let file = scenario_file(case, k, &files);
        let out = cwd.join("out-folder");
        let mut child = bin()
            .current_dir(&cwd)
            .arg("run")
            .arg(&file)
            .arg("--out")
            .arg(&out)
            .arg("--quiet")
            .args(case.args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let t0 = Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            if t0.elapsed() > limit {
                let _ = child.kill();
                let _ = child.wait();
                panic!(
                    "case {k} ({:?} {:?}): still running after {limit:?}",
                    case.edits, case.args
                );
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        let mut err = String::new();
        std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
        let first = err.lines().next().unwrap_or("");
        let what = format!(
            "case {k} ({} {:?} {:?})",
            case.base.lines().next().unwrap_or(""),
            case.edits,
            case.args
        );
        if status.success() {
            failures.push(format!("{what}: accepted"));
        } else if status.code() == Some(101) || err.contains("panicked") {
            failures.push(format!("{what}: panic: {err}"));
        } else if !(first.starts_with("error:") && case.expect.iter().all(|n| first.contains(n))) {
            failures.push(format!("{what}: expected {:?} in: {first}", case.expect));
        }
        let left: Vec<_> = std::fs::read_dir(&cwd)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        if !left.is_empty() {
            failures.push(format!("{what}: created {left:?}"));
            std::fs::remove_dir_all(&cwd).unwrap();
            std::fs::create_dir_all(&cwd).unwrap();
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases:\n{}",
        failures.len(),
        CASES.len(),
        failures.join("\n")
    );
    assert!(CASES.len() >= 100, "{} cases", CASES.len());
}
