//! The scenario's reading, overrides and validation.

use super::*;

const GOOD: &str = r#"(
    name: "t",
    mesh: Regular(width: 10.0, height: 10.0, h: 1.0),
    material: (young: 20e9, poisson: 0.2, density: 2700.0),
    boundary: InSitu(sxx: -20e6, syy: -10e6),
    time: (end: Static(tol: 1e-8)),
)"#;

#[test]
fn parses_and_validates() {
    let sc = Scenario::parse(GOOD, "good.ron")
        .unwrap()
        .validate()
        .unwrap();
    assert_eq!(sc.time.safety, 0.9);
    assert_eq!(sc.damping, Damping::Local(0.8));
}

#[test]
fn unknown_field_names_line_column_and_field() {
    let bad = GOOD.replace("density: 2700.0", "density: 2700.0, colour: 1.0");
    let e = Scenario::parse(&bad, "bad.ron").unwrap_err().to_string();
    assert!(e.starts_with("bad.ron:4:"), "{e}");
    assert!(e.contains("colour"), "{e}");
}

#[test]
fn wrong_type_names_the_field() {
    let bad = GOOD.replace("poisson: 0.2", "poisson: \"x\"");
    let e = Scenario::parse(&bad, "bad.ron").unwrap_err().to_string();
    assert!(e.starts_with("bad.ron:4:"), "{e}");
    assert!(e.contains("material.poisson"), "{e}");
}

#[test]
fn non_physical_values_are_named() {
    for (from, to, field) in [
        ("poisson: 0.2", "poisson: 0.5", "material.poisson"),
        ("young: 20e9", "young: -1.0", "material.young"),
        ("young: 20e9", "young: 1e15", "material.young"),
        ("density: 2700.0", "density: 1e308", "material.density"),
        (
            "tol: 1e-8)",
            "tol: 1e-8), newton_easy: 0",
            "time.newton_easy",
        ),
        (
            "tol: 1e-8)",
            "tol: 1e-8), newton_easy: 21",
            "time.newton_easy",
        ),
        (
            "tol: 1e-8)",
            "tol: 1e-8), newton_tol: 1e-2",
            "time.newton_tol",
        ),
        (
            "tol: 1e-8)",
            "tol: 1e-8), newton_tol: NaN",
            "time.newton_tol",
        ),
        ("h: 1.0", "h: 20.0", "mesh.h"),
    ] {
        let sc = Scenario::parse(&GOOD.replace(from, to), "x.ron").unwrap();
        let e = sc.validate().unwrap_err().to_string();
        assert!(e.contains(field), "{e}");
    }
}

/// Poisson's ratio above `MAX_COUPLED_POISSON` is refused for a coupled run only (the
/// seed's fluid volume does not bound its pressure there; README "Reliability"), naming the
/// field, the limit and the reason; the same rock without flow is accepted up to 0.5.
#[test]
fn coupled_runs_refuse_a_nearly_incompressible_rock() {
    let coupled = GOOD.replace(
        "time: (end",
        "fracture: Some((preexisting: [(from: (0.0, 5.0), to: (3.0, 5.0))])),\n        \
         flow_boundaries: [(name: \"pump\", at: Node((0.0, 5.0)), \
         kind: Pump(p_max: 18e6, q_half: 2.0))],\n        time: (end",
    );
    let sc = Scenario::parse(&coupled, "coupled.ron").unwrap();
    sc.clone().validate().unwrap();
    for nu in ["0.48", "0.45", "0"] {
        let o = sc
            .with_overrides(&[format!("material.poisson={nu}")])
            .unwrap();
        o.validate().unwrap();
    }
    for nu in ["0.481", "0.49", "0.499"] {
        let o = sc
            .with_overrides(&[format!("material.poisson={nu}")])
            .unwrap();
        let e = o.validate().unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("invalid material.poisson: {nu} is above 0.48")),
            "{e}"
        );
        assert!(
            e.contains("L max(delta_n, a_r)") && e.contains("p_max") && !e.contains('\n'),
            "{e}"
        );
    }
    // Without flow boundaries (the same fracture, dry) and without fractures: accepted.
    let dry = Scenario::parse(&coupled, "dry.ron")
        .unwrap()
        .with_overrides(&["flow_boundaries=[]".into(), "material.poisson=0.499".into()])
        .unwrap();
    dry.validate().unwrap();
    let plain = Scenario::parse(&GOOD.replace("poisson: 0.2", "poisson: 0.499"), "x.ron");
    plain.unwrap().validate().unwrap();
}

/// A byte-order mark before the scenario is skipped (it failed at 1:1).
#[test]
fn a_byte_order_mark_is_accepted() {
    let sc = Scenario::parse(&format!("\u{feff}{GOOD}"), "bom.ron").unwrap();
    assert_eq!(sc, Scenario::parse(GOOD, "good.ron").unwrap());
}

/// A NaN of the file is reported as the file's value when an override touches another
/// field (the JSON the overrides go through turns it into `null`), and an override of that
/// very field replaces it.
#[test]
fn a_non_finite_value_of_the_file_is_not_blamed_on_an_override() {
    let sc = Scenario::parse(&GOOD.replace("young: 20e9", "young: NaN"), "nan.ron").unwrap();
    let e = sc
        .with_overrides(&["damping=None".into()])
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("invalid material.young:"), "{e}");
    assert!(e.contains("scenario file"), "{e}");
    let o = sc.with_overrides(&["material.young=3e10".into()]).unwrap();
    assert_eq!(o.material.unwrap().young, 3e10);
    // A bad override (of a field read before: the JSON fields are read in alphabetical
    // order) is still the override's.
    let e = sc
        .with_overrides(&["damping=Wild".into()])
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("--set"), "{e}");
}

#[test]
fn overrides_reach_into_variants_and_validate() {
    let sc = Scenario::parse(GOOD, "good.ron").unwrap();
    let o = sc
        .with_overrides(&[
            "material.young=3e10".into(),
            "mesh.h=0.5".into(),
            "damping=None".into(),
        ])
        .unwrap();
    assert_eq!(o.material.unwrap().young, 3e10);
    assert_eq!(o.mesh.as_ref().unwrap().h(), Some(0.5));
    assert_eq!(o.damping, Damping::None);
    let o = sc
        .with_overrides(&["damping=Local(0.5)".into(), "time.end=Time(2.5)".into()])
        .unwrap();
    assert_eq!(o.damping, Damping::Local(0.5));
    assert_eq!(o.time.end, End::Time(2.5));
    // A list of structs with unit variants as RON writes it; an empty list.
    let box3 = Scenario::parse(
        "(name: \"b\", mesh: GradedBox(size: (4.0, 4.0, 4.0), h: 0.5, \
         fine: (1.0, 1.0, 1.0, 3.0, 3.0, 3.0), ratio: 1.2), \
         material: (young: 2e10, poisson: 0.2, density: 2700.0), \
         boundary: InSitu3(sxx: -1e6, syy: -1e6, szz: -1e6), time: (end: Static(tol: 1e-8)))",
        "b.ron",
    )
    .unwrap();
    let o = box3
        .with_overrides(&[
            "mesh.refine=[(axis: X, at: 2.0, factor: 4.0), (axis: Z, at: 1.5, factor: 2.0, \
             ratio: 1.3),]"
                .into(),
        ])
        .unwrap();
    let MeshSpec::GradedBox { refine, .. } = o.mesh.as_ref().unwrap() else {
        panic!("a graded box");
    };
    assert_eq!(refine.len(), 2);
    assert_eq!(
        (refine[0].axis, refine[0].at, refine[0].ratio),
        (Axis::X, 2.0, 1.5)
    );
    assert_eq!(
        (refine[1].axis, refine[1].factor, refine[1].ratio),
        (Axis::Z, 2.0, 1.3)
    );
    let o = o.with_overrides(&["mesh.refine=[]".into()]).unwrap();
    // A tuple as RON writes it.
    let o = o
        .with_overrides(&["mesh.fine=(0.5, 0.5, 0.5, 3.5, 3.5, 3.5)".into()])
        .unwrap();
    assert!(
        matches!(o.mesh, Some(MeshSpec::GradedBox { fine, .. }) if fine == [0.5, 0.5, 0.5, 3.5, 3.5, 3.5])
    );
    assert!(matches!(o.mesh, Some(MeshSpec::GradedBox { ref refine, .. }) if refine.is_empty()));
    // An optional number as RON writes it.
    let o = sc
        .with_overrides(&["time.selective_mass_scaling=Some(4.0)".into()])
        .unwrap();
    assert_eq!(o.time.selective_mass_scaling, Some(4.0));
    // A struct variant in RON's words: the whole mesh replaced.
    let o = sc
        .with_overrides(&["mesh=Conforming(width: 8.0, height: 6.0, h: 0.5, h_far: 2.0)".into()])
        .unwrap();
    let m = o.mesh.as_ref().unwrap();
    assert_eq!((m.h(), m.kind()), (Some(0.5), "Conforming"));
    // `None` for an optional field, as RON writes it, beside a unit variant `None`.
    let with = Scenario::parse(
        &GOOD.replace(
            "time:",
            "production: Some((wells: (injection: (0.0, 5.0), production: (10.0, 5.0), \
             production_pressure: 0.0, pressure_drops: [1e6], reach: 1.0))), time:",
        ),
        "p.ron",
    )
    .unwrap();
    assert!(with.production.is_some());
    let o = with
        .with_overrides(&["production=None".into(), "damping=None".into()])
        .unwrap();
    assert!(o.production.is_none());
    assert_eq!(o.damping, Damping::None);
    let e = sc
        .with_overrides(&["material.colour=1".into()])
        .unwrap_err()
        .to_string();
    assert!(e.contains("density") && e.contains("young"), "{e}");
    let e = sc
        .with_overrides(&["material.young=abc".into()])
        .unwrap_err()
        .to_string();
    assert!(e.contains("material.young"), "{e}");
}
