//! Sample preparation as in the thesis (2.2, 3.2.1): radii drawn from a size distribution,
//! grains sprinkled into the region at a fraction of their size and grown until they fill it
//! at the target isotropic stress with the grain friction lowered to `f_gg'`; the friction is
//! then raised to the test value `f_gg''`, the global solver (the minimisation) brings the
//! packing to exact equilibrium with it, and, for a cemented material, every grain-grain
//! contact is bonded.

use super::grow::{grow, GrowReport, GrowSettings};
use super::{sprinkle, ContactHistory, Region, SampleFile, SizeDistribution};
use crate::geometry::{Circle, GrainSet, Side, Wall, WallControl, WallSet};
use crate::measure::Measurements;
use crate::simulation::{initial_contacts, MaterialModel, Simulation, StageProgram};
use crate::solver::{SolverConfig, Strategy};
use crate::state::State;
use crate::{Error, InputError};

/// The shape of the region a sample fills.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RegionShape {
    /// A rectangle of height / width `aspect` (biaxial and shear tests).
    Rectangle,
    /// An annulus of outer / inner radius `aspect` (the thick-walled cylinder test).
    Annulus,
    /// A beam of length / height `aspect` (the three-point bend test).
    Beam,
}

/// What to prepare.
#[derive(Debug, Clone, PartialEq)]
pub struct PrepareSpec {
    /// Region shape.
    pub shape: RegionShape,
    /// Height / width (rectangle), outer / inner radius (annulus), length / height (beam).
    pub aspect: f64,
    /// Number of grains.
    pub grains: usize,
    /// Size distribution of the radii.
    pub distribution: SizeDistribution,
    /// Seed of the radii and of the sprinkling.
    pub seed: u64,
    /// Grain friction while growing, `f_gg'`.
    pub friction: f64,
    /// Target isotropic stress (Pa).
    pub stress: f64,
    /// Size at which the grains are sprinkled, as a fraction of their own.
    pub start_fraction: f64,
    /// Solid fraction the region is sized for at the start; the walls then find their place.
    pub solid_fraction: f64,
    /// Depth `D` (m); default the mean diameter.
    pub depth: Option<f64>,
}

/// A prepared sample, with what the preparation measured.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The sample to write.
    pub sample: SampleFile,
    /// The state at the end (walls where they ended), for a test to start from.
    pub state: State,
    /// Measurements of the final state (contacts per grain exclude wall contacts).
    pub measurements: Measurements,
    /// How the growth went.
    pub growth: GrowReport,
    /// Relative residual of the final equilibrium.
    pub residual: f64,
    /// Depth used (m).
    pub depth: f64,
}

/// The region of `spec` sized so that the grains fill `solid_fraction` of it.
fn region(spec: &PrepareSpec, radii: &[f64]) -> Region {
    let area: f64 = radii
        .iter()
        .map(|r| std::f64::consts::PI * r * r)
        .sum::<f64>()
        / spec.solid_fraction;
    let a = spec.aspect;
    match spec.shape {
        RegionShape::Rectangle => {
            let width = (area / a).sqrt();
            Region::Rectangle {
                width,
                height: a * width,
            }
        }
        RegionShape::Beam => {
            let height = (area / a).sqrt();
            Region::Beam {
                length: a * height,
                height,
            }
        }
        RegionShape::Annulus => {
            let inner = (area / (std::f64::consts::PI * (a * a - 1.0))).sqrt();
            Region::Annulus {
                inner_radius: inner,
                outer_radius: a * inner,
            }
        }
    }
}

/// The walls that hold a region while it is prepared: a box whose bottom and left walls stay
/// and whose top and right walls carry the stress, or a ring and a plug that both carry it.
fn region_walls(region: &Region, stress: f64) -> WallSet {
    let line = |name: &str, normal: [f64; 2], offset: f64, stressed: bool| Wall {
        name: name.into(),
        normal,
        offset,
        pivot: [offset * normal[0], offset * normal[1]],
        turn: 0.0,
        position: 0.0,
        slide: 0.0,
        control: if stressed {
            WallControl::Stress
        } else {
            WallControl::Displacement
        },
        stress: if stressed { stress } else { 0.0 },
        length: None,
        friction: 0.0,
        circle: None,
    };
    let walls = match *region {
        Region::Rectangle { width, height }
        | Region::Beam {
            length: width,
            height,
        } => vec![
            line("bottom", [0.0, 1.0], 0.0, false),
            line("right", [-1.0, 0.0], -width, true),
            line("top", [0.0, -1.0], -height, true),
            line("left", [1.0, 0.0], 0.0, false),
        ],
        Region::Annulus {
            inner_radius,
            outer_radius,
        } => {
            let circle = |name: &str, radius: f64, grains_inside: bool| Wall {
                normal: [0.0; 2],
                circle: Some(Circle {
                    center: [0.0; 2],
                    radius,
                    grains_inside,
                    moves: None,
                }),
                ..line(name, [0.0; 2], 0.0, true)
            };
            vec![
                circle("outer", outer_radius, true),
                circle("inner", inner_radius, false),
            ]
        }
    };
    WallSet { walls }
}

/// Prepare a sample of `material` as `spec` says, solving the final equilibrium as `config`
/// says. `file` names the scene in errors; `progress` sees (step, steps planned) of growth.
pub fn prepare(
    spec: &PrepareSpec,
    material: &MaterialModel,
    config: &SolverConfig,
    file: &str,
    progress: impl FnMut(usize, usize),
) -> Result<Prepared, Error> {
    let input = |key: &str, e: &dyn std::fmt::Display| {
        Error::from(InputError::new(file, e.to_string()).at_key(key))
    };
    let radii = spec.distribution.radii(spec.grains, spec.seed);
    let region = region(spec, &radii);
    region.check().map_err(|e| input("sample", &e))?;
    let mut grains = sprinkle(&region, &radii, spec.start_fraction, spec.seed)
        .map_err(|e| input("sample.start_fraction", &e))?;
    let depth = spec.depth.unwrap_or(2.0 * grains.mean_radius());
    let mut walls = region_walls(&region, spec.stress);

    // Growth with f_gg', the walls holding the target stress.
    // Disturbances cross the sample in a time that grows as the square root of the number of
    // grains (its width in diameters); growth and rest scale with it.
    let crossings = (spec.grains as f64 / 1000.0).sqrt().max(1.0);
    let growth_steps = (4000.0 * crossings) as usize;
    let settings = GrowSettings {
        friction: spec.friction,
        stress: spec.stress,
        growth_steps,
        max_rest_steps: 20 * growth_steps,
        patience: 5 * growth_steps,
        ..GrowSettings::default()
    };
    let (growth, shear_forces) = grow(
        &mut grains,
        &mut walls,
        material,
        depth,
        spec.start_fraction,
        &settings,
        progress,
    );

    // Exact equilibrium at the target stress with the friction raised to f_gg''. Growth
    // hands on a packing near rest, not at it. Without friction such a packing is close to
    // isostatic: held to exact equilibrium with f_gg' = 0, a grain near a mechanism pulls on
    // a neighbour, and once that contact is let go it collapses into a new arrangement (the
    // 10,000-grain annulus: 39 contacts in tension, then no equilibrium). With f_gg'' the
    // shear springs hold it where growth left it, as they hold it in the tests that start
    // from it; the density is the one f_gg' gave.
    let uncemented = MaterialModel {
        bonded: false,
        ..material.clone()
    };
    let skin = config.skin * grains.mean_radius();
    let mut contacts = initial_contacts(&uncemented, &grains, &walls, skin);
    for c in &mut contacts.contacts {
        if let Ok(k) = shear_forces.binary_search_by(|(p, _)| p.cmp(&c.pair)) {
            c.shear_force0 = shear_forces[k].1;
        }
    }
    let hold = StageProgram {
        name: "equilibrium".into(),
        increments: 1,
        stress: walls
            .walls
            .iter()
            .map(|w| (w.control == WallControl::Stress).then_some(spec.stress))
            .collect(),
        normal_move: vec![0.0; walls.len()],
        slide: vec![0.0; walls.len()],
        shear_strain: vec![0.0; walls.len()],
        glue: vec![false; walls.len()],
        pressure: Vec::new(),
        control: Vec::new(),
        until_failure: false,
        failure_drop: None,
        breakouts: false,
        until_breakout: false,
    };
    let state = State::fresh(grains, walls, contacts, Vec::new());
    // The global solver, whatever strategy the settings name: 20 sweeps would leave it
    // unbalanced. The load is held, so halving the step would not help.
    let exact = SolverConfig {
        strategy: Strategy::Minimise,
        max_cuts: 0,
        ..config.clone()
    };
    let mut sim = Simulation::from_state(
        "prepare".into(),
        exact,
        uncemented,
        depth,
        vec![hold],
        state,
    )?;
    let report = sim.run_increment()?;

    // Cement for a bonded material. The prepared state is the start of whatever uses it: no
    // increments, no stages done.
    let mut state = sim.state;
    (state.increment, state.stage, state.stage_increment) = (0, 0, 0);
    let mut bonds = Vec::new();
    for c in &mut state.contacts.contacts {
        if let Side::Grain(a) = c.pair.a {
            c.params = material.params(c.pair, &state.grains, &state.walls);
            if material.bonded {
                c.bonded = true;
                bonds.push((a, c.pair.b));
            }
        }
    }
    let measurements = report.measurements.clone();
    let sample = SampleFile {
        grains: rebased(&state.grains),
        region,
        distribution: Some(spec.distribution),
        seed: spec.seed,
        description: format!(
            "{:?} of {} grains, f_gg' = {}, prepared to {} Pa",
            spec.shape, spec.grains, spec.friction, spec.stress
        ),
        stress: spec.stress,
        contacts_per_grain: measurements.contacts_per_grain,
        bonds,
        walls: state.walls.clone(),
        contacts: state
            .contacts
            .contacts
            .iter()
            .map(|c| ContactHistory {
                pair: c.pair,
                shear_force: c.shear_force0,
                shear_displacement: c.shear_displacement0,
            })
            .collect(),
    };
    Ok(Prepared {
        sample,
        state,
        measurements,
        growth,
        residual: report.residual,
        depth,
    })
}

/// The grains as they are, as the start of whatever uses the sample.
fn rebased(grains: &GrainSet) -> GrainSet {
    GrainSet {
        rotation: vec![0.0; grains.len()],
        ..GrainSet::new(grains.position.clone(), grains.radius.clone())
    }
}
