//! The scene file (TOML): what is simulated — grains, material, walls, load program, output.
//!
//! A scene says *what*; how it is solved is a separate solver file (see [`crate::solver::SolverConfig`]).
//! Every length is in metres, every stress in pascals, every force in newtons. Loading a scene
//! checks it completely: unknown keys, wrong types and out-of-range values are
//! [`InputError`](crate::InputError)s that name the file, the key and the line.

mod load;
mod validate;

pub use load::{build_grains, load_scene, load_solver, parse_scene, parse_solver};
pub(crate) use load::{child_key, read_grain_csv};
pub(crate) use validate::start_overlap;

use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;

/// A whole scene, as read from its TOML file.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Short name, used in the output and the progress line.
    #[serde(default = "default_name")]
    pub name: String,
    /// Free text describing the scene.
    #[serde(default)]
    pub description: String,
    /// Grain material and contact law.
    pub material: Material,
    /// Where the grains are (absent in a scene that only prepares a sample).
    #[serde(default)]
    pub grains: GrainSource,
    /// How to prepare a sample (`grainstat generate`): region, size distribution, grain count,
    /// seed, `f_gg'` and target stress.
    #[serde(default)]
    pub sample: Option<SampleSpec>,
    /// Four walls around the grains' bounding box (bottom, right, top, left), if wanted.
    #[serde(default, rename = "box")]
    pub wall_box: Option<WallBox>,
    /// Straight rigid walls, in addition to those of `box`.
    #[serde(default)]
    pub walls: Vec<WallSpec>,
    /// Circular rigid walls: rings around the grains, plugs among them.
    #[serde(default)]
    pub circles: Vec<CircleSpec>,
    /// Membranes: pressure on the outermost grains, following them.
    #[serde(default)]
    pub membranes: Vec<MembraneSpec>,
    /// Regions whose stress is measured from their grains' contact forces (eq. A.40).
    #[serde(default)]
    pub regions: Vec<RegionSpec>,
    /// The load program: stages applied one after another.
    #[serde(default)]
    pub stages: Vec<Stage>,
    /// Where and how often the state is written.
    #[serde(default)]
    pub output: OutputSpec,
}

fn default_name() -> String {
    "scene".into()
}

/// The contact law of the grains (thesis section 2.1).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum LawKind {
    /// Linear springs with tension cut-off and cracking: cemented grains, eqs. 8-12.
    Linear,
    /// Hertz-Mindlin: sand, eqs. 1-7.
    Hertz,
}

/// Which radius product sets the bond strength `F_t` (eq. 12).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
pub enum CohesionRadius {
    /// `F_t = c_mu * rbar^2` with `rbar = 2 r_i r_j / (r_i + r_j)`.
    #[default]
    Mean,
    /// `F_t = c_mu * r_i * r_j`.
    Product,
}

/// Grain material (table 1 for sand, table 8 for sandstone).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// The contact law.
    pub law: LawKind,
    /// Normal spring stiffness `k_n` (N/m) (linear law).
    #[serde(default)]
    pub normal_stiffness: Option<f64>,
    /// Shear modulus of the grain material `G_mu` (Pa) (Hertz law).
    #[serde(default)]
    pub shear_modulus: Option<f64>,
    /// Poisson's ratio of the grain material `nu_mu`; sets `kappa = 3(1-nu)/(2-nu)`.
    #[serde(default = "default_poisson")]
    pub poisson: f64,
    /// Grain-grain friction `f_gg = tan(phi_mu)`; `"infinite"` for no slip.
    #[serde(default = "default_friction")]
    pub friction: Friction,
    /// Cohesion `c_mu` (N/m^2): bond strength `F_t = c_mu * r^2` (linear law only).
    #[serde(default)]
    pub cohesion: f64,
    /// Which radius product the bond strength uses.
    #[serde(default)]
    pub cohesion_radius: CohesionRadius,
    /// Anisotropic cohesion (thesis 4.4.4): the bond strength of a horizontal contact as a
    /// fraction of a vertical one's, in [0, 1] (the thesis's breakout cylinder: 0.5). In
    /// between it goes as `F_t(theta) = F_t (f cos^2 theta + sin^2 theta)`, `theta` the
    /// angle of the contact normal from the horizontal. Default 1: isotropic.
    #[serde(default = "one_f64")]
    pub cohesion_horizontal: f64,
    /// Bond every grain-grain contact present at the start (cemented sample).
    #[serde(default)]
    pub bonded: bool,
    /// Hold every grain's rotation fixed (thesis 3.2.2): 2 unknowns per grain instead of 3.
    #[serde(default)]
    pub fixed_rotations: bool,
    /// Depth `D` (m) that turns 2D forces into stresses; default: the mean grain diameter.
    #[serde(default)]
    pub depth: Option<f64>,
}

fn one_f64() -> f64 {
    1.0
}

fn default_poisson() -> f64 {
    0.16
}

fn default_friction() -> Friction {
    Friction::Coefficient(0.6)
}

/// A friction coefficient, or none at all to slip against (`"infinite"`, `"glued"`).
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
#[serde(untagged)]
pub enum Friction {
    /// Coulomb friction coefficient `f >= 0`.
    Coefficient(f64),
    /// No slip ever.
    #[serde(serialize_with = "serialize_infinite")]
    Infinite,
}

fn serialize_infinite<S: serde::Serializer>(s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str("infinite")
}

impl Friction {
    /// The coefficient, `f64::INFINITY` for no slip.
    pub fn value(self) -> f64 {
        match self {
            Friction::Coefficient(f) => f,
            Friction::Infinite => f64::INFINITY,
        }
    }
}

impl<'de> Deserialize<'de> for Friction {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Friction;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a friction coefficient (a number >= 0) or \"infinite\" / \"glued\"")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Friction, E> {
                Ok(Friction::Coefficient(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Friction, E> {
                Ok(Friction::Coefficient(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Friction, E> {
                Ok(Friction::Coefficient(v as f64))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Friction, E> {
                match v {
                    "infinite" | "glued" | "inf" => Ok(Friction::Infinite),
                    _ => Err(E::invalid_value(serde::de::Unexpected::Str(v), &self)),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// Where the grains come from: a CSV file, inline lists, a hexagonal crystal, or a prepared
/// sample file. Exactly one of them.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct GrainSource {
    /// CSV file of `x, y, r` per line (relative to the scene file).
    #[serde(default)]
    pub file: Option<String>,
    /// Inline x coordinates (m).
    #[serde(default)]
    pub x: Vec<f64>,
    /// Inline y coordinates (m).
    #[serde(default)]
    pub y: Vec<f64>,
    /// Inline radii (m).
    #[serde(default)]
    pub r: Vec<f64>,
    /// A regular hexagonal crystal of equal grains.
    #[serde(default)]
    pub crystal: Option<CrystalSpec>,
    /// A prepared sample (HDF5, see [`crate::sample::write_sample`]), relative to the scene
    /// file: its grains exactly as saved, displacements and rotations included.
    #[serde(default)]
    pub sample: Option<String>,
    /// With `sample`: start from the prepared equilibrium itself. The sample's walls named
    /// here stay where they ended, each with the control this test gives it (a wall turned
    /// to stress control starts at the stress the sample was prepared to), the others go;
    /// every contact keeps its shear force and bond. The scene's own walls come after them.
    #[serde(default)]
    pub walls: Option<BTreeMap<String, WallControl>>,
}

/// Equal grains in a hexagonal arrangement: horizontal rows, each row shifted by one radius
/// from the last; rows alternate between `columns` and `columns - 1` grains (thesis chapter 5:
/// 21 rows of 15 and 20 rows of 16 is `rows = 41, columns = 16` starting with a short row).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CrystalSpec {
    /// Number of horizontal rows.
    pub rows: usize,
    /// Grains in a long row.
    pub columns: usize,
    /// Grain radius (m).
    pub radius: f64,
    /// Whether the first (bottom) row is a short one.
    #[serde(default = "yes")]
    pub short_first: bool,
}

fn yes() -> bool {
    true
}

/// How a wall's normal position is governed.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
pub enum WallControl {
    /// Prescribed: moved by the load program's displacements only (default: held in place).
    #[default]
    Displacement,
    /// An unknown of the global system, loaded by `stress * length * depth`.
    Stress,
}

/// The names of the four walls `box` makes, in this order.
pub const BOX_SIDES: [&str; 4] = ["bottom", "right", "top", "left"];

/// Four walls on the grains' bounding box.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WallBox {
    /// Friction between grains and these walls (`f_gw`).
    #[serde(default = "zero_friction")]
    pub friction: Friction,
    /// Sides that are stress-controlled (`bottom`, `right`, `top`, `left`); the others are
    /// displacement-controlled.
    #[serde(default)]
    pub stress_controlled: Vec<String>,
    /// Stress on the stress-controlled sides at the start (Pa).
    #[serde(default)]
    pub stress: f64,
}

fn zero_friction() -> Friction {
    Friction::Coefficient(0.0)
}

/// One straight rigid wall: the line through `point` with unit `normal` pointing into the sample.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    /// Name used by the load program.
    pub name: String,
    /// A point on the wall line (m).
    pub point: [f64; 2],
    /// Normal pointing into the sample (normalised on load).
    pub normal: [f64; 2],
    /// Friction between grains and this wall (`f_gw`).
    #[serde(default = "zero_friction")]
    pub friction: Friction,
    /// Displacement- or stress-controlled.
    #[serde(default)]
    pub control: WallControl,
    /// Stress at the start (Pa) (stress-controlled walls).
    #[serde(default)]
    pub stress: f64,
    /// Loaded length (m); default: the distance between the two walls perpendicular to it.
    #[serde(default)]
    pub length: Option<f64>,
}

/// One stage of the load program: `increments` equal steps from the state the last stage left.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Stage {
    /// Name shown in the log.
    #[serde(default)]
    pub name: String,
    /// Number of load increments in this stage.
    pub increments: usize,
    /// Walls whose control changes from this stage on, e.g. `control = { top = "displacement" }`
    /// after an isotropic stage: a wall turned to stress control starts at the stress the
    /// grains put on it, one turned to displacement control stays where it is.
    #[serde(default)]
    pub control: BTreeMap<String, WallControl>,
    /// Stress each named stress-controlled wall reaches at the end of the stage (Pa).
    #[serde(default)]
    pub stress: BTreeMap<String, f64>,
    /// Normal displacement (into the sample positive) each named displacement-controlled wall
    /// makes over the stage (m).
    #[serde(default)]
    pub displacement: BTreeMap<String, f64>,
    /// Tangential displacement each named wall makes over the stage (m) (along the wall, the
    /// normal turned 90 degrees anticlockwise).
    #[serde(default)]
    pub shear: BTreeMap<String, f64>,
    /// Shear strain `gamma` each named straight wall imposes over the stage (rad), as the top
    /// of a simple shear box: the walls across it (its span walls, a box's left and right)
    /// turn by `gamma` about their pivots (a box's side walls: their bottom ends), clockwise
    /// for a positive `gamma`, and the wall slides along itself (along its tangent, the
    /// normal turned a quarter anticlockwise: +x for a box's top) so that its corners stay on
    /// them: by its distance from the wall facing it times the change of `tan gamma`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub shear_strain: BTreeMap<String, f64>,
    /// Straight walls that glue the grains touching them when the stage starts (thesis 3.3.4:
    /// the simple shear box, `f_gw` infinite and the grains glued so they cannot roll). A glued
    /// grain moves with its wall as a part of it from then on.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub glue: Vec<String>,
    /// Load until the sample fails (`until_failure = true`): a load-controlled test that
    /// reaches collapse has no equilibrium beyond it, so an increment of this stage that
    /// finds no equilibrium near (grains carried on while the potential falls, the load
    /// bracketed by halving) ends the test there. The last converged state is written, the
    /// run says at which increment and load the sample failed, and it ends with exit status
    /// 0. Without it (the default) such an increment is an error (exit status 3), as an
    /// increment the solver gives up on is in any stage.
    #[serde(default)]
    pub until_failure: bool,
    /// In a stage loaded until failure, the sample has failed too once the force on a wall
    /// the stage pushes (displacement-controlled and moved) falls below this fraction of its
    /// peak in the stage: a brittle beam that breaks through may still find an equilibrium
    /// in pieces. The increment that shows the drop is written and ends the test. Where a
    /// bond cascade at one wall displacement takes the force below it and the solver then
    /// gives up on the rubble the cascade goes on to leave, the cascade's first equilibrium
    /// past the drop is the increment's: the brittle failure is established there.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure_drop: Option<f64>,
    /// In a stage loaded until failure, a cluster of grains that breaks out of the sample (no
    /// equilibrium near holds it: the cylinder test's borehole surface, thesis 4.4.2) is
    /// taken out and recorded, and loading goes on; the sample has failed when what finds no
    /// equilibrium is more than a tenth of its grains.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub breakouts: bool,
    /// With `breakouts`, the test ends at its first breakout: the cylinder test's
    /// functional failure (thesis 4.4.2), the moment the borehole loses its function. The
    /// cluster is recorded and taken out, and the sample's collapse after it is not followed.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub until_breakout: bool,
}

/// Where the state goes.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// HDF5 file (relative to the working directory); `-o` overrides it.
    #[serde(default)]
    pub file: Option<String>,
    /// Write every `every`-th increment (the last one is always written).
    #[serde(default = "one")]
    pub every: usize,
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            file: None,
            every: 1,
        }
    }
}

fn one() -> usize {
    1
}

/// The sample section of a scene: what `grainstat generate` prepares (thesis 2.2, 3.2.1).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SampleSpec {
    /// `"rectangle"`, `"annulus"` or `"beam"`.
    pub region: crate::sample::prepare::RegionShape,
    /// Height / width (rectangle, default 2.5), outer / inner radius (annulus, default 3),
    /// length / height (beam, default 5).
    #[serde(default)]
    pub aspect: Option<f64>,
    /// Number of grains.
    pub grains: usize,
    /// Size distribution: `{ kind = "a", mean_radius = 1e-4, ratio = 4 }` (appendix 4).
    pub distribution: crate::sample::SizeDistribution,
    /// Seed of the radii and of the sprinkling.
    #[serde(default)]
    pub seed: u64,
    /// Grain friction while growing, `f_gg'`: 0 gives the densest sample.
    #[serde(default)]
    pub friction: f64,
    /// Isotropic stress the sample is prepared to (Pa).
    pub stress: f64,
    /// Size at which grains are sprinkled, as a fraction of their own (default 0.5).
    #[serde(default = "half")]
    pub start_fraction: f64,
    /// Solid fraction the region is sized for at the start (default 0.75).
    #[serde(default = "three_quarters")]
    pub solid_fraction: f64,
}

fn half() -> f64 {
    0.5
}

fn three_quarters() -> f64 {
    0.75
}

impl SampleSpec {
    /// The aspect ratio, or the default of the region.
    pub fn aspect(&self) -> f64 {
        use crate::sample::prepare::RegionShape;
        self.aspect.unwrap_or(match self.region {
            RegionShape::Rectangle => 2.5,
            RegionShape::Annulus => 3.0,
            RegionShape::Beam => 5.0,
        })
    }
}

/// Where the grains are relative to a circular wall.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum CircleSide {
    /// Inside the circle: the wall is a ring around them.
    Inside,
    /// Outside the circle: the wall is a plug among them.
    Outside,
}

/// A circular rigid wall.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CircleSpec {
    /// Name used by the load program.
    pub name: String,
    /// Centre (m).
    pub center: [f64; 2],
    /// Radius (m).
    pub radius: f64,
    /// Whether the grains are `"inside"` (a ring) or `"outside"` (a plug).
    pub grains: CircleSide,
    /// Friction between grains and this wall (`f_gw`).
    #[serde(default = "zero_friction")]
    pub friction: Friction,
    /// Displacement-controlled (held, or moved into the sample by `displacement`) or
    /// stress-controlled (its radius an unknown loaded by `stress * circumference * depth`).
    #[serde(default)]
    pub control: WallControl,
    /// Stress at the start (Pa) (stress-controlled).
    #[serde(default)]
    pub stress: f64,
    /// A plug whose centre moves, in this direction (normalised), instead of growing: a
    /// loading point. Its stress is its force along the direction over `2 radius depth`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub moves: Option<[f64; 2]>,
    /// Bring a moving plug from `center` along `moves` (either way) to where it first touches
    /// the grains, so supports and a loading point start in contact with a sample whose
    /// grains the scene cannot know exactly.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub touch: bool,
}

/// A membrane: a pressure on the outermost grains that follows them.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MembraneSpec {
    /// Name used by the load program (`stress = { NAME = ... }` sets its pressure).
    pub name: String,
    /// A side membrane: the direction pointing out of the sample through that side.
    #[serde(default)]
    pub side: Option<[f64; 2]>,
    /// A membrane all around the sample, about this centre (m).
    #[serde(default)]
    pub ring: Option<[f64; 2]>,
    /// Pressure at the start (Pa).
    #[serde(default)]
    pub pressure: f64,
}

/// A region of the plane, fixed in space, whose stress is measured each increment from the
/// contact forces on the grains whose centres lie in it (eq. A.40 over the region's area):
/// a rectangle (`min`, `max`), a circle (`center`, `radius`) or a ring (also
/// `inner_radius`).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RegionSpec {
    /// Name in the result file and the curves.
    pub name: String,
    /// A rectangle's lower left corner (m).
    #[serde(default)]
    pub min: Option<[f64; 2]>,
    /// A rectangle's upper right corner (m).
    #[serde(default)]
    pub max: Option<[f64; 2]>,
    /// A circle's or ring's centre (m).
    #[serde(default)]
    pub center: Option<[f64; 2]>,
    /// A circle's radius, a ring's outer radius (m).
    #[serde(default)]
    pub radius: Option<f64>,
    /// A ring's inner radius (m).
    #[serde(default)]
    pub inner_radius: Option<f64>,
}
