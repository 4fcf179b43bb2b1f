//! The rock and how it is held (`material:`, `boundary:`, `initial_state:`, `pins:`,
//! `damping:`, `gravity:`) and those sections' checks.

use super::finite;
use super::positive;
use crate::error::SetupError;
use serde::{Deserialize, Serialize};

/// Linear elastic rock.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Young's modulus E, Pa.
    pub young: f64,
    /// Poisson's ratio nu, 0 <= nu < 0.5.
    pub poisson: f64,
    /// Density rho, kg/m^3.
    pub density: f64,
}

impl Material {
    /// Lame's first parameter lambda, Pa.
    pub fn lambda(&self) -> f64 {
        self.young * self.poisson / ((1.0 + self.poisson) * (1.0 - 2.0 * self.poisson))
    }
    /// Shear modulus G, Pa.
    pub fn shear(&self) -> f64 {
        self.young / (2.0 * (1.0 + self.poisson))
    }
    /// P-wave speed c_p = sqrt((lambda + 2G)/rho), m/s.
    pub fn p_wave_speed(&self) -> f64 {
        ((self.lambda() + 2.0 * self.shear()) / self.density).sqrt()
    }
    /// Plane-strain strains (exx, eyy) that give the stresses (sxx, syy) with sxy = 0:
    /// exx = ((1-nu^2) sxx - nu(1+nu) syy)/E, and symmetrically.
    pub fn plane_strain_strain(&self, sxx: f64, syy: f64) -> (f64, f64) {
        let (e, nu) = (self.young, self.poisson);
        (
            ((1.0 - nu * nu) * sxx - nu * (1.0 + nu) * syy) / e,
            ((1.0 - nu * nu) * syy - nu * (1.0 + nu) * sxx) / e,
        )
    }
}

/// Boundary conditions on the four sides of the rectangular domain.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Boundary {
    /// Normal displacements on all four sides computed by plane-strain Hooke's law so that the
    /// unfractured body carries the uniform stress (sxx, syy), Pa, tension positive. The domain
    /// centre stays put; tangential motion along the sides is free.
    InSitu { sxx: f64, syy: f64 },
    /// One condition per side.
    Sides {
        #[serde(default)]
        left: SideBc,
        #[serde(default)]
        right: SideBc,
        #[serde(default)]
        bottom: SideBc,
        #[serde(default)]
        top: SideBc,
    },
    /// 3D: normal displacements on all six sides of the box by 3D Hooke's law so that the
    /// unfractured body carries the principal stresses (sxx, syy, szz) along the axes, Pa,
    /// tension positive. The box's centre stays put; tangential motion is free.
    InSitu3 { sxx: f64, syy: f64, szz: f64 },
    /// 3D: one condition per side of the box (`front`/`back`: y = min/max; `bottom`/`top`:
    /// z = min/max). A traction is normal only (`shear: 0`).
    Sides3 {
        #[serde(default)]
        left: SideBc,
        #[serde(default)]
        right: SideBc,
        #[serde(default)]
        front: SideBc,
        #[serde(default)]
        back: SideBc,
        #[serde(default)]
        bottom: SideBc,
        #[serde(default)]
        top: SideBc,
    },
}

impl Boundary {
    /// Whether the boundary is a 3D box's (`InSitu3`, `Sides3`).
    pub fn is_3d(&self) -> bool {
        matches!(self, Boundary::InSitu3 { .. } | Boundary::Sides3 { .. })
    }
}

impl Default for Boundary {
    fn default() -> Self {
        Boundary::Sides {
            left: SideBc::Free,
            right: SideBc::Free,
            bottom: SideBc::Free,
            top: SideBc::Free,
        }
    }
}

/// The solid's state at t = 0.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum InitialState {
    /// Undeformed, at rest.
    #[default]
    Rest,
    /// The homogeneous plane-strain displacement of the in-situ stress, u = (exx (x - xc),
    /// eyy (y - yc)) about the domain centre, at rest.
    InSitu,
}

/// Condition on one side.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum SideBc {
    /// Traction-free.
    #[default]
    Free,
    /// Prescribed displacement along the outward normal, m (negative = pushed inwards);
    /// tangential motion free.
    Normal(f64),
    /// Both displacement components zero.
    Fixed,
    /// Traction, Pa: `normal` along the outward normal (tension positive, so a confining
    /// pressure p is `normal: -p`), `shear` along the side's counter-clockwise tangent.
    Traction { normal: f64, shear: f64 },
}

/// Largest Young's modulus accepted, Pa, and largest density, kg/m^3 (see `validate`).
pub const MAX_YOUNG: f64 = 1e14;
/// Smallest Young's modulus accepted, Pa: far below any rock (soft sediment is about 1e7 Pa,
/// a hydrogel 1e3); a subnormal modulus (5e-324) made the critical step 1e162 s and the first
/// step's speeds 1e166 m/s.
pub const MIN_YOUNG: f64 = 1e3;
pub const MAX_DENSITY: f64 = 1e9;

/// A prescribed displacement on the node nearest to `at` (within half a cell diagonal).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Pin {
    /// Position, m: (x, y), or (x, y, z) on a 3D mesh.
    pub at: Coords,
    /// Prescribed x displacement, m (`None`: free).
    #[serde(default)]
    pub ux: Option<f64>,
    /// Prescribed y displacement, m (`None`: free).
    #[serde(default)]
    pub uy: Option<f64>,
    /// Prescribed z displacement, m (`None`: free; 3D only).
    #[serde(default)]
    pub uz: Option<f64>,
}

/// Damping for pseudo-static response.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Damping {
    /// Undamped central difference (energy-conserving dynamics).
    None,
    /// Local non-viscous damping (Cundall): each force component is reduced by
    /// `alpha * |F| * sign(v)`, 0 <= alpha < 1. Does not change the static solution and needs
    /// no frequency; the usual choice for dynamic relaxation. Default 0.8.
    Local(f64),
    /// Mass-proportional viscous damping with coefficient c, 1/s (force -c m v).
    Viscous(f64),
}

impl Default for Damping {
    fn default() -> Self {
        Damping::Local(0.8)
    }
}

impl Material {
    /// Young's modulus, density and Poisson's ratio in their ranges; errors name
    /// `material.<field>`. (A coupled run's smaller limit on Poisson's ratio is
    /// `Scenario::check_coupled_poisson`'s.)
    pub(super) fn validate(&self) -> Result<(), SetupError> {
        positive("material.young", self.young, "Young's modulus")?;
        positive("material.density", self.density, "the density")?;
        // Upper bounds far above any rock (diamond: E 1.2e12 Pa; osmium: 22,600 kg/m^3),
        // so the energies and stresses (E u, rho v^2 A) stay finite: a density of 1e308
        // made the kinetic energy inf * 0 = NaN (the fuzzer's finding, kept in
        // tests/fuzz_regressions/).
        if self.young < MIN_YOUNG {
            return Err(SetupError::invalid(
                "material.young",
                format!(
                    "{:e} Pa is below {MIN_YOUNG:e} Pa (rock is 1e9 to 1e11 Pa): the \
                     critical step and the displacements would not be physical",
                    self.young
                ),
            ));
        }
        if self.young > MAX_YOUNG {
            return Err(SetupError::invalid(
                "material.young",
                format!(
                    "{:e} Pa is above {MAX_YOUNG:e} Pa (diamond is 1.2e12 Pa): energies \
                     and stresses would overflow",
                    self.young
                ),
            ));
        }
        if self.density > MAX_DENSITY {
            return Err(SetupError::invalid(
                "material.density",
                format!(
                    "{:e} kg/m^3 is above {MAX_DENSITY:e} kg/m^3 (rock is 2,000-3,500; \
                     room is left for mass scaling): the kinetic energy would overflow",
                    self.density
                ),
            ));
        }
        finite("material.poisson", self.poisson)?;
        if !(0.0..0.5).contains(&self.poisson) {
            return Err(SetupError::invalid(
                "material.poisson",
                format!(
                    "Poisson's ratio must be in [0, 0.5) (0.5 is incompressible and not \
                     representable by plane-strain CST), got {}",
                    self.poisson
                ),
            ));
        }
        Ok(())
    }
}

impl Boundary {
    /// Every load and displacement finite; errors name `boundary.<field>`.
    pub(super) fn validate(&self) -> Result<(), SetupError> {
        match self {
            Boundary::InSitu { sxx, syy } => {
                finite("boundary.sxx", *sxx)?;
                finite("boundary.syy", *syy)?;
            }
            Boundary::Sides {
                left,
                right,
                bottom,
                top,
            } => {
                for (name, bc) in [
                    ("left", left),
                    ("right", right),
                    ("bottom", bottom),
                    ("top", top),
                ] {
                    bc.validate(name)?;
                }
            }
            Boundary::InSitu3 { sxx, syy, szz } => {
                finite("boundary.sxx", *sxx)?;
                finite("boundary.syy", *syy)?;
                finite("boundary.szz", *szz)?;
            }
            Boundary::Sides3 { .. } => {
                for (name, bc) in self.sides3().into_iter().flatten() {
                    bc.validate(name)?;
                    if let SideBc::Traction { shear, .. } = bc
                        && shear != 0.0
                    {
                        return Err(SetupError::invalid(
                            &format!("boundary.{name}.shear"),
                            "a shear traction on a 3D side has no direction yet: use 0",
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

impl Boundary {
    /// A `Sides3` boundary's sides with their names, in the order left, right, front, back,
    /// bottom, top (`Side::ALL3`'s); `None` for the other boundaries.
    pub fn sides3(&self) -> Option<[(&'static str, SideBc); 6]> {
        match *self {
            Boundary::Sides3 {
                left,
                right,
                front,
                back,
                bottom,
                top,
            } => Some([
                ("left", left),
                ("right", right),
                ("front", front),
                ("back", back),
                ("bottom", bottom),
                ("top", top),
            ]),
            _ => None,
        }
    }
}

impl SideBc {
    /// The side `name`'s values finite.
    fn validate(&self, name: &str) -> Result<(), SetupError> {
        match self {
            SideBc::Normal(d) => finite(&format!("boundary.{name}"), *d),
            SideBc::Traction { normal, shear } => {
                finite(&format!("boundary.{name}.normal"), *normal)?;
                finite(&format!("boundary.{name}.shear"), *shear)
            }
            SideBc::Free | SideBc::Fixed => Ok(()),
        }
    }
}

impl Pin {
    /// Finite position and displacements, at least one of them prescribed; errors name
    /// `field` (`pins[i]`).
    pub(super) fn validate(&self, field: &str) -> Result<(), SetupError> {
        for &v in self.at.given().iter().chain(&[
            self.ux.unwrap_or(0.0),
            self.uy.unwrap_or(0.0),
            self.uz.unwrap_or(0.0),
        ]) {
            finite(field, v)?;
        }
        if self.ux.is_none() && self.uy.is_none() && self.uz.is_none() {
            return Err(SetupError::invalid(field, "prescribes none of ux, uy, uz"));
        }
        Ok(())
    }
}

impl Damping {
    /// Local damping in [0, 1), viscous damping >= 0; errors name `damping`.
    pub(super) fn validate(&self) -> Result<(), SetupError> {
        match *self {
            Damping::Local(a) => {
                finite("damping", a)?;
                if !(0.0..1.0).contains(&a) {
                    return Err(SetupError::invalid(
                        "damping",
                        format!("local damping must be in [0, 1), got {a}"),
                    ));
                }
            }
            Damping::Viscous(c) => {
                finite("damping", c)?;
                if c < 0.0 {
                    return Err(SetupError::invalid(
                        "damping",
                        format!("viscous damping must be >= 0, got {c}"),
                    ));
                }
            }
            Damping::None => {}
        }
        Ok(())
    }
}

/// Two or three numbers, read and written as a tuple: a point or a vector, `(x, y)` on a 2D
/// mesh (y up), `(x, y, z)` on a 3D one (z up). Gravity (m/s^2) and pin positions (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coords {
    /// The components, the third 0 in 2D.
    pub v: [f64; 3],
    /// How many components the scenario gave (2 or 3).
    pub components: usize,
}

/// Gravity's acceleration, m/s^2: `(gx, gy)` in 2D, `(gx, gy, gz)` in 3D.
pub type Gravity = Coords;

impl Coords {
    /// Two components (x, y).
    pub fn two(v: [f64; 2]) -> Self {
        Coords {
            v: [v[0], v[1], 0.0],
            components: 2,
        }
    }

    /// Three components (x, y, z).
    pub fn three(v: [f64; 3]) -> Self {
        Coords { v, components: 3 }
    }

    /// The in-plane components (x, y).
    pub fn xy(&self) -> [f64; 2] {
        [self.v[0], self.v[1]]
    }

    /// The components given.
    pub fn given(&self) -> &[f64] {
        &self.v[..self.components]
    }
}

impl Serialize for Coords {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        let mut t = s.serialize_tuple(self.components)?;
        for c in self.given() {
            t.serialize_element(c)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for Coords {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Coords;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("(x, y) in 2D or (x, y, z) in 3D")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut a: A) -> Result<Coords, A::Error> {
                let mut v = [0.0; 3];
                let mut n = 0;
                while let Some(x) = a.next_element::<f64>()? {
                    if n == 3 {
                        return Err(serde::de::Error::invalid_length(4, &self));
                    }
                    v[n] = x;
                    n += 1;
                }
                if n < 2 {
                    return Err(serde::de::Error::invalid_length(n, &self));
                }
                Ok(Coords { v, components: n })
            }
        }
        d.deserialize_tuple(3, V)
    }
}

/// Gravity (m/s^2) finite; errors name `gravity`.
pub(super) fn validate_gravity(gravity: Option<Gravity>) -> Result<(), SetupError> {
    if let Some(g) = gravity {
        for x in g.given() {
            finite("gravity", *x)?;
        }
    }
    Ok(())
}
