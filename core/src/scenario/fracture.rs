//! Fracturing of the rock (`fracture:`): the criterion, the joints, the pre-existing fractures
//! (listed, from a CSV file, or a seeded random network) and the section's checks.

use super::{RandomNetwork, finite, positive};
use crate::error::SetupError;
use serde::{Deserialize, Serialize};

/// Fracture criterion parameters.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FractureSpec {
    /// lambda * T0, Pa: an internal edge is fracture-ready when the normal stress across it
    /// (tension positive) reaches this (seed equation (7); the seed uses 1 MPa at h = 1 m).
    /// lambda is a mesh-size calibration; the value may be negative when the criterion is
    /// calibrated under confinement (the near-zero-toughness KGD case uses -s0 + 0.5 MPa).
    /// `None`: no criterion, only the pre-existing fractures.
    #[serde(default)]
    pub strength: Option<f64>,
    /// The criterion by name: `Some(Strength(lambda_t0))` is the same as `strength`;
    /// `Some(Toughness(k_ic: ..., initiation: ...))` grows fractures at their tips when the
    /// equivalent stress intensity reaches K_Ic (Pa sqrt(m)), with the strength test (Pa,
    /// optional) starting new fractures away from the tips (`systems::toughness`). Give either
    /// this or `strength`, not both.
    #[serde(default)]
    pub criterion: Option<CriterionSpec>,
    /// Which stress the criterion reads on a face: `Patch` (default), the area-weighted mean of
    /// the elements touching the edge's ends that lie alongside it, or `Elements`, the mean of
    /// the two elements beside the edge. See `systems::fracture::fracture_criterion`.
    #[serde(default)]
    pub face_stress: FaceStress,
    /// The strength test's hand-over at fracture tips: a fracture-ready face that is the far
    /// side of a triangle at a tip node touches no tip, so no node can split and the fracture
    /// stops; with the hand-over its mark also goes to the edge of that triangle at the tip
    /// that best continues the fracture (`systems::fracture::hand_over`). `None` (default): on
    /// for meshes that are not the seed's grids (`Conforming`, `Gmsh`), where tips meet such
    /// triangles; off on `Regular`, `Perturbed` and `Graded`, where the seed's rule runs as
    /// written. No effect under `Toughness`, which marks edges at the tips itself.
    #[serde(default)]
    pub tip_handover: Option<bool>,
    /// 3D only: where fractures may grow. `Anywhere` (default): the criterion tests every
    /// internal rock face. `DiscPlanes`: only the faces that lie on a disc's plane (its normal
    /// along the disc's, its centroid on the plane, anywhere on that plane), so the discs grow
    /// in their planes and nowhere else: the planar growth of the radial hydraulic-fracture
    /// benchmark (as PyFrac grows its fronts in one plane and GEOS's penny-shaped cases confine
    /// the split to a fracture region).
    #[serde(default)]
    pub grow_in: GrowIn,
    /// Residual hydraulic aperture a_r, m (seed: 0.5 mm).
    #[serde(default = "default_residual_aperture")]
    pub residual_aperture: f64,
    /// Fractures present at the start, snapped to mesh edges and opened by node splitting.
    #[serde(default)]
    pub preexisting: Vec<PreFracture>,
    /// 3D only: planar disc fractures present at the start, each made of the mesh faces that
    /// lie on its plane with their centroid inside it, opened by node splitting at setup. On a
    /// `Box` or `GradedBox` put the disc on a grid plane (its normal along an axis).
    #[serde(default)]
    pub discs: Vec<Disc>,
    /// A seeded random network of pre-existing fractures (added to `preexisting`), snapped and
    /// opened as they are; written to `preexisting_fractures.csv` with each one's snapping
    /// error.
    #[serde(default)]
    pub random: Option<RockNetwork>,
    /// Pre-existing fractures from a CSV file (relative to the scenario file) with a header
    /// line and columns `x0,y0,x1,y1` (m), e.g. a mapped network (added to `preexisting`).
    #[serde(default)]
    pub file: Option<String>,
    /// A uniform pressure on the faces of every fracture, Pa (prescribed; in coupled runs the
    /// flow solver supplies the face pressures instead).
    #[serde(default)]
    pub pressure: Option<f64>,
    /// Joint friction angle phi, degrees (Coulomb: |F_t| <= F_n tan phi). Default 30.
    #[serde(default = "default_friction")]
    pub friction_deg: f64,
    /// Slip-weakening friction (`docs/seismicity.md`): the friction angle falls from
    /// `friction_deg` to a residual angle over a critical slip. Default: constant Coulomb
    /// friction.
    #[serde(default)]
    pub slip_weakening: Option<super::SlipWeakening>,
    /// Joint normal and shear penalty stiffness K_n, K_t, Pa (force per unit thickness per unit
    /// offset). Default: the rock's E and G, as in the seed.
    #[serde(default)]
    pub normal_stiffness: Option<f64>,
    #[serde(default)]
    pub shear_stiffness: Option<f64>,
}

impl FractureSpec {
    /// Pre-existing joints only: `preexisting` fractures with friction angle `friction_deg`
    /// (degrees), residual aperture `residual_aperture` (m) and penalty stiffnesses K_n, K_t
    /// (Pa; `None`: the rock's E and G); no criterion, no generated network, no prescribed
    /// pressure, constant friction (set the other fields on the result).
    pub fn joints(
        preexisting: Vec<PreFracture>,
        friction_deg: f64,
        residual_aperture: f64,
        stiffness: Option<(f64, f64)>,
    ) -> Self {
        FractureSpec {
            random: None,
            file: None,
            strength: None,
            criterion: None,
            face_stress: Default::default(),
            tip_handover: None,
            grow_in: GrowIn::Anywhere,
            residual_aperture,
            preexisting,
            discs: Vec::new(),
            pressure: None,
            friction_deg,
            slip_weakening: None,
            normal_stiffness: stiffness.map(|k| k.0),
            shear_stiffness: stiffness.map(|k| k.1),
        }
    }
}

/// The fracture criterion (`fracture.criterion`).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum CriterionSpec {
    /// The seed's: a face opens when its normal stress reaches lambda*T0, Pa (tension
    /// positive; as `fracture.strength`).
    Strength(f64),
    /// Linear elastic fracture mechanics at the tips: a tip grows by one edge, in the direction
    /// of the maximum hoop stress, when K_eq >= `k_ic` (Pa sqrt(m)). `initiation` (Pa, tension
    /// positive): the strength test on faces away from every tip, so fractures can also start
    /// where there is no tip; `None`: only tips grow.
    #[serde(rename_all = "snake_case")]
    Toughness {
        k_ic: f64,
        #[serde(default)]
        initiation: Option<f64>,
    },
}

/// The stress the fracture criterion reads on a face.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum FaceStress {
    #[default]
    Patch,
    Elements,
}

/// Where fractures may grow in 3D (`fracture.grow_in`).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum GrowIn {
    /// Every internal rock face is a candidate.
    #[default]
    Anywhere,
    /// Only the faces on the planes of the scenario's discs.
    DiscPlanes,
}

fn default_friction() -> f64 {
    30.0
}

/// Residual hydraulic aperture a_r when a scenario gives none, m (the seed's 0.5 mm).
pub const DEFAULT_RESIDUAL_APERTURE: f64 = 5e-4;

fn default_residual_aperture() -> f64 {
    DEFAULT_RESIDUAL_APERTURE
}

/// A pre-existing fracture: a straight segment, m.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PreFracture {
    pub from: [f64; 2],
    pub to: [f64; 2],
}

/// A planar disc fracture in 3D: centre (m), normal (any length but zero) and radius (m).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Disc {
    pub center: [f64; 3],
    pub normal: [f64; 3],
    pub radius: f64,
}

impl Disc {
    /// The unit normal.
    pub fn unit_normal(&self) -> [f64; 3] {
        let l = crate::tet4::norm(self.normal);
        self.normal.map(|c| c / l)
    }

    /// Centre, normal and radius finite; the normal not zero, the radius positive.
    fn validate(&self, field: &str) -> Result<(), SetupError> {
        for v in self.center.iter().chain(&self.normal) {
            finite(field, *v)?;
        }
        positive(&format!("{field}.radius"), self.radius, "the disc's radius")?;
        let n2: f64 = self.normal.iter().map(|c| c * c).sum();
        if !(n2.is_finite() && n2 > 0.0) {
            return Err(SetupError::invalid(
                &format!("{field}.normal"),
                "the disc's normal must be a non-zero, finite vector",
            ));
        }
        Ok(())
    }
}

/// Most fractures of a random network in the rock (each is snapped by a shortest-path search
/// over the mesh).
pub const MAX_ROCK_FRACTURES: usize = 10_000;

/// A seeded (ChaCha8) random network of fractures in the rock: `count` fractures with centres
/// uniform in the box `origin`..`origin + size` (m), orientation `angles_deg[k] +- jitter_deg`
/// (degrees from the x axis, a family chosen uniformly per fracture), length uniform in
/// `length` (m); clipped to the box. Their apertures come from the joints (residual aperture
/// when closed).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RockNetwork {
    pub seed: u64,
    pub count: usize,
    #[serde(default)]
    pub origin: [f64; 2],
    pub size: [f64; 2],
    pub angles_deg: Vec<f64>,
    #[serde(default)]
    pub jitter_deg: f64,
    pub length: [f64; 2],
}

impl RockNetwork {
    /// As the rigid network's generator sees it (apertures unused).
    fn as_random(&self) -> RandomNetwork {
        RandomNetwork {
            seed: self.seed,
            count: self.count,
            origin: self.origin,
            size: self.size,
            angles_deg: self.angles_deg.clone(),
            jitter_deg: self.jitter_deg,
            length: self.length,
            aperture: [1.0, 1.0],
        }
    }

    /// The fractures, generated by [`RandomNetwork::generate`] (the same seed gives the same
    /// fractures).
    pub fn generate(&self) -> Vec<PreFracture> {
        self.as_random()
            .generate()
            .into_iter()
            .map(|f| PreFracture {
                from: f.from,
                to: f.to,
            })
            .collect()
    }

    /// [`RandomNetwork::validate_geometry`] and the count limit; errors name `field.<field>`.
    pub fn validate(&self, field: &str) -> Result<(), SetupError> {
        if self.count > MAX_ROCK_FRACTURES {
            return Err(SetupError::invalid(
                &format!("{field}.count"),
                format!("{} fractures: at most {MAX_ROCK_FRACTURES}", self.count),
            ));
        }
        self.as_random().validate_geometry(field)
    }
}

/// Read pre-existing fractures from CSV text (header line, then `x0,y0,x1,y1` per line, m;
/// blank lines skipped). Errors name the file and line.
pub fn read_fracture_csv(text: &str, file: &str) -> Result<Vec<PreFracture>, SetupError> {
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let v: Vec<&str> = line.split(',').map(str::trim).collect();
        let nums: Option<Vec<f64>> = v.iter().map(|x| x.parse::<f64>().ok()).collect();
        match nums {
            Some(n) if n.len() == 4 && n.iter().all(|x| x.is_finite()) => out.push(PreFracture {
                from: [n[0], n[1]],
                to: [n[2], n[3]],
            }),
            _ => {
                return Err(SetupError::invalid(
                    "fracture.file",
                    format!(
                        "{file}:{}: `{line}` is not four finite numbers x0,y0,x1,y1 (m)",
                        k + 1
                    ),
                ));
            }
        }
        if out.len() > MAX_ROCK_FRACTURES {
            return Err(SetupError::invalid(
                "fracture.file",
                format!("{file}: more than {MAX_ROCK_FRACTURES} fractures"),
            ));
        }
    }
    Ok(out)
}

impl FractureSpec {
    /// Every pre-existing fracture with the field it comes from: the listed ones
    /// (`fracture.preexisting[i]`), then the file's (`fracture.file[i]`), then the random
    /// network's (`fracture.random[i]`).
    pub fn all_preexisting(&self) -> Result<Vec<(PreFracture, String)>, SetupError> {
        let mut all: Vec<(PreFracture, String)> = self
            .preexisting
            .iter()
            .enumerate()
            .map(|(i, f)| (*f, format!("fracture.preexisting[{i}]")))
            .collect();
        if let Some(f) = &self.file {
            let text = std::fs::read_to_string(f).map_err(|e| {
                SetupError::invalid("fracture.file", format!("cannot read {f}: {e}"))
            })?;
            let list = read_fracture_csv(&text, f)?;
            all.extend(
                list.into_iter()
                    .enumerate()
                    .map(|(i, p)| (p, format!("fracture.file[{i}]"))),
            );
        }
        if let Some(r) = &self.random {
            r.validate("fracture.random")?;
            all.extend(
                r.generate()
                    .into_iter()
                    .enumerate()
                    .map(|(i, p)| (p, format!("fracture.random[{i}]"))),
            );
        }
        Ok(all)
    }

    /// The criterion, the residual aperture, the face pressure, the joints' friction and
    /// stiffnesses, the listed fractures and the random network; errors name
    /// `fracture.<field>`. (That it needs a mesh is `Scenario::check_fracture_has_mesh`'s.)
    pub(super) fn validate(&self) -> Result<(), SetupError> {
        self.validate_criterion()?;
        positive(
            "fracture.residual_aperture",
            self.residual_aperture,
            "the residual aperture",
        )?;
        if let Some(p) = self.pressure {
            finite("fracture.pressure", p)?;
        }
        finite("fracture.friction_deg", self.friction_deg)?;
        if !(0.0..90.0).contains(&self.friction_deg) {
            return Err(SetupError::invalid(
                "fracture.friction_deg",
                format!(
                    "the joint friction angle must be in [0, 90) degrees, got {}",
                    self.friction_deg
                ),
            ));
        }
        if let Some(w) = &self.slip_weakening {
            w.validate(self.friction_deg)?;
        }
        if let Some(k) = self.normal_stiffness {
            positive("fracture.normal_stiffness", k, "the joint normal stiffness")?;
        }
        if let Some(k) = self.shear_stiffness {
            positive("fracture.shear_stiffness", k, "the joint shear stiffness")?;
        }
        for (i, pf) in self.preexisting.iter().enumerate() {
            for v in [pf.from[0], pf.from[1], pf.to[0], pf.to[1]] {
                finite(&format!("fracture.preexisting[{i}]"), v)?;
            }
        }
        if let Some(r) = &self.random {
            r.validate("fracture.random")?;
        }
        for (i, d) in self.discs.iter().enumerate() {
            d.validate(&format!("fracture.discs[{i}]"))?;
        }
        Ok(())
    }

    /// `strength` finite, or `criterion` (not both) with finite values and a toughness >= 0.
    fn validate_criterion(&self) -> Result<(), SetupError> {
        if let Some(st) = self.strength {
            // May be negative: a criterion calibrated at mesh size h under a confining
            // stress s0 is lambda*T0 = c K_Ic / sqrt(h) - s0 (see scenarios/kgd.ron).
            finite("fracture.strength", st)?;
        }
        match self.criterion {
            Some(_) if self.strength.is_some() => Err(SetupError::invalid(
                "fracture.criterion",
                "give either fracture.strength or fracture.criterion, not both",
            )),
            Some(CriterionSpec::Strength(st)) => finite("fracture.criterion", st),
            Some(CriterionSpec::Toughness { k_ic, initiation }) => {
                finite("fracture.criterion.k_ic", k_ic)?;
                if k_ic < 0.0 {
                    return Err(SetupError::invalid(
                        "fracture.criterion.k_ic",
                        format!("the fracture toughness must be >= 0 Pa sqrt(m), got {k_ic}"),
                    ));
                }
                match initiation {
                    Some(st) => finite("fracture.criterion.initiation", st),
                    None => Ok(()),
                }
            }
            None => Ok(()),
        }
    }
}
