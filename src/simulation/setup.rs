//! From a scene to a simulation: walls (a box and/or explicit lines), the material's contact
//! properties, the load program, and the first contact set.

use super::Simulation;
use crate::contact::{
    hertz_stiffness, kappa, mean_radius, Contact, ContactLaw, ContactParams, ContactSet,
    HertzMindlin, LinearCohesive,
};
use crate::geometry::{
    Circle, FriendSet, GrainSet, Membrane, MembraneShape, Pair, Side, Wall, WallControl, WallSet,
};
use crate::measure::Region;
use crate::scene::{CircleSide, CohesionRadius, LawKind, Scene};
use crate::solver::{SolverConfig, Strategy};
use crate::state::State;
use crate::{Error, InputError};

/// Contact properties of the grain material and the walls.
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialModel {
    /// Which law.
    pub law: LawKind,
    /// `k_n` (N/m) (linear law).
    pub normal_stiffness: f64,
    /// `G_mu` (Pa) (Hertz law).
    pub shear_modulus: f64,
    /// `nu_mu`.
    pub poisson: f64,
    /// `f_gg`.
    pub friction: f64,
    /// `c_mu` (N/m^2).
    pub cohesion: f64,
    /// Radius product of the bond strength.
    pub cohesion_radius: CohesionRadius,
    /// Bond strength of a horizontal contact over a vertical one's (thesis 4.4.4).
    pub cohesion_horizontal: f64,
    /// Whether the contacts present at the start are cemented.
    pub bonded: bool,
    /// Whether grain rotations are held fixed.
    pub fixed_rotations: bool,
}

impl MaterialModel {
    /// The material of a scene.
    pub fn from_scene(scene: &Scene) -> Self {
        let m = &scene.material;
        MaterialModel {
            law: m.law,
            normal_stiffness: m.normal_stiffness.unwrap_or(0.0),
            shear_modulus: m.shear_modulus.unwrap_or(0.0),
            poisson: m.poisson,
            friction: m.friction.value(),
            cohesion: m.cohesion,
            cohesion_radius: m.cohesion_radius,
            cohesion_horizontal: m.cohesion_horizontal,
            bonded: m.bonded,
            fixed_rotations: m.fixed_rotations,
        }
    }

    /// The law object.
    pub fn law(&self) -> Box<dyn ContactLaw> {
        match self.law {
            LawKind::Linear => Box::new(LinearCohesive),
            LawKind::Hertz => Box::new(HertzMindlin),
        }
    }

    /// A typical normal stiffness (N/m): `k_n`, or the Hertz tangent at an overlap of a
    /// thousandth of the radius.
    pub fn stiffness_hint(&self, r_mean: f64) -> f64 {
        match self.law {
            LawKind::Linear => self.normal_stiffness,
            LawKind::Hertz => {
                let m = hertz_stiffness(r_mean, self.shear_modulus, self.poisson);
                1.5 * m * (1e-3 * r_mean).sqrt()
            }
        }
    }

    /// The normal tangent stiffness (N/m) of a contact between grains of radius `r` that
    /// carries `force` (N): `k_n`, or the Hertz tangent `1.5 M^(2/3) F^(1/3)`.
    pub fn stiffness_at(&self, r: f64, force: f64) -> f64 {
        match self.law {
            LawKind::Linear => self.normal_stiffness,
            LawKind::Hertz => {
                let m = hertz_stiffness(r, self.shear_modulus, self.poisson);
                1.5 * m.powf(2.0 / 3.0) * force.cbrt()
            }
        }
    }

    /// The share of the full bond strength a contact along `branch` gets (thesis 4.4.4): the
    /// horizontal factor `f` at 0 degrees, 1 at 90, `f cos^2 + sin^2` in between. The thesis
    /// halves the horizontal bonds without saying how the angles between vary; `cos^2` is the
    /// smoothest form with those ends, the one a second-order fabric tensor gives.
    pub fn cohesion_factor(&self, branch: [f64; 2]) -> f64 {
        let f = self.cohesion_horizontal;
        if f == 1.0 {
            return 1.0;
        }
        let squared = branch[0] * branch[0] + branch[1] * branch[1];
        if squared == 0.0 {
            return 1.0;
        }
        let cos2 = branch[0] * branch[0] / squared;
        f * cos2 + (1.0 - cos2)
    }

    /// Properties of a contact between the two sides of `pair`; a bond's strength is set by
    /// the direction of its contact when the contact is made.
    pub fn params(&self, pair: Pair, grains: &GrainSet, walls: &WallSet) -> ContactParams {
        let rb = grains.radius[pair.b];
        let (ra, friction) = match pair.a {
            Side::Grain(a) => (Some(grains.radius[a]), self.friction),
            Side::Wall(w) => (None, walls.walls[w].friction),
        };
        let rbar = mean_radius(rb, ra);
        let stiffness = match self.law {
            LawKind::Linear => self.normal_stiffness,
            LawKind::Hertz => hertz_stiffness(rbar, self.shear_modulus, self.poisson),
        };
        let strength = match (pair.a, self.cohesion_radius) {
            (Side::Wall(_), _) => 0.0,
            (Side::Grain(a), radius) => {
                let size = match radius {
                    CohesionRadius::Mean => rbar * rbar,
                    CohesionRadius::Product => grains.radius[a] * rb,
                };
                self.cohesion * size * self.cohesion_factor(grains.branch(a, pair.b))
            }
        };
        ContactParams {
            stiffness,
            kappa: kappa(self.poisson),
            friction,
            strength,
        }
    }
}

/// One stage of the load program, resolved to wall indices.
#[derive(Debug, Clone, PartialEq)]
pub struct StageProgram {
    /// Name for the log.
    pub name: String,
    /// Increments in the stage.
    pub increments: usize,
    /// Stress each wall reaches at the end of the stage (`None`: unchanged).
    pub stress: Vec<Option<f64>>,
    /// Normal move of each wall over the stage (m).
    pub normal_move: Vec<f64>,
    /// Move along each wall over the stage (m).
    pub slide: Vec<f64>,
    /// Shear strain each wall imposes over the stage, as the top of a shear box (see
    /// [`crate::scene::Stage::shear_strain`]).
    pub shear_strain: Vec<f64>,
    /// The walls that glue the grains touching them when the stage starts.
    pub glue: Vec<bool>,
    /// Pressure each membrane reaches at the end of the stage (`None`: unchanged).
    pub pressure: Vec<Option<f64>>,
    /// Control of each wall during the stage: the scene's, as the stages so far changed it
    /// (empty: the walls keep the controls they have).
    pub control: Vec<WallControl>,
    /// Whether an increment that does not converge ends the test as the sample's failure
    /// rather than as an error (see [`crate::scene::Stage::until_failure`]).
    pub until_failure: bool,
    /// The fraction of its peak force below which a pushed wall's force means failure (see
    /// [`crate::scene::Stage::failure_drop`]).
    pub failure_drop: Option<f64>,
    /// Whether clusters that break out are taken out and loading goes on (see
    /// [`crate::scene::Stage::breakouts`]).
    pub breakouts: bool,
    /// Whether the stage ends at its first breakout ([`crate::scene::Stage::until_breakout`]).
    pub until_breakout: bool,
}

/// The walls of a scene: the four of `box` (bottom, right, top, left) on the grains' bounding
/// box, then the explicit ones.
pub fn build_walls(scene: &Scene, grains: &GrainSet) -> WallSet {
    let mut walls = Vec::new();
    if let Some(b) = &scene.wall_box {
        let [x0, y0, x1, y1] = grains.bounding_box();
        let sides = [
            ("bottom", [x0, y0], [0.0, 1.0]),
            ("right", [x1, y0], [-1.0, 0.0]),
            ("top", [x0, y1], [0.0, -1.0]),
            ("left", [x0, y0], [1.0, 0.0]),
        ];
        for (name, point, normal) in sides {
            let stress_side = b.stress_controlled.iter().any(|s| s == name);
            walls.push(Wall {
                name: name.into(),
                normal,
                offset: normal[0] * point[0] + normal[1] * point[1],
                pivot: point,
                turn: 0.0,
                position: 0.0,
                slide: 0.0,
                control: if stress_side {
                    WallControl::Stress
                } else {
                    WallControl::Displacement
                },
                stress: if stress_side { b.stress } else { 0.0 },
                length: None,
                friction: b.friction.value(),
                circle: None,
            });
        }
    }
    for spec in &scene.walls {
        let len = spec.normal[0].hypot(spec.normal[1]);
        let normal = [spec.normal[0] / len, spec.normal[1] / len];
        walls.push(Wall {
            name: spec.name.clone(),
            normal,
            offset: normal[0] * spec.point[0] + normal[1] * spec.point[1],
            pivot: spec.point,
            turn: 0.0,
            position: 0.0,
            slide: 0.0,
            control: spec.control,
            stress: spec.stress,
            length: spec.length,
            friction: spec.friction.value(),
            circle: None,
        });
    }
    for spec in &scene.circles {
        let moves = spec.moves.map(|m| {
            let len = m[0].hypot(m[1]);
            [m[0] / len, m[1] / len]
        });
        walls.push(Wall {
            name: spec.name.clone(),
            normal: [0.0; 2],
            offset: 0.0,
            pivot: spec.center,
            turn: 0.0,
            position: 0.0,
            slide: 0.0,
            control: spec.control,
            stress: spec.stress,
            // A moving plug loads its diameter: its stress is the force over 2 r D.
            length: moves.map(|_| 2.0 * spec.radius),
            friction: spec.friction.value(),
            circle: Some(Circle {
                center: match (moves, spec.touch) {
                    (Some(m), true) => touching(spec.center, spec.radius, m, grains),
                    _ => spec.center,
                },
                radius: spec.radius,
                grains_inside: spec.grains == CircleSide::Inside,
                moves,
            }),
        });
    }
    WallSet { walls }
}

/// The walls a stage shears and glues must make a shear box the solver can move: a wall
/// sheared needs a wall facing it and two walls across it (its span walls), and those must
/// turn about points on the facing wall, which stays where it is; the grain-by-grain solver
/// does not move glued grains with their walls.
fn check_shear_boxes(
    scene: &Scene,
    walls: &WallSet,
    strategy: Strategy,
    file: &str,
) -> Result<(), Error> {
    for (i, stage) in scene.stages.iter().enumerate() {
        for name in stage.shear_strain.keys() {
            let key = crate::scene::child_key(&format!("stages[{i}].shear_strain"), name);
            let bad =
                |message: String| Err(InputError::new(file, message).at_key(key.clone()).into());
            let Some(w) = walls.walls.iter().position(|x| &x.name == name) else {
                continue;
            };
            let (Some(facing), Some((a, b))) = (walls.facing(w), walls.span_walls(w)) else {
                return bad(format!(
                    "wall `{name}` needs a wall facing it and two walls across it to shear a box"
                ));
            };
            let bottom = &walls.walls[facing];
            for side in [a, b] {
                let pivot = walls.walls[side].pivot;
                let off = bottom.normal[0] * pivot[0] + bottom.normal[1] * pivot[1] - bottom.offset;
                if off.abs() > 1e-9 * walls.gap(w, facing).abs() {
                    return bad(format!(
                        "wall `{}` turns about a point {off:e} m off wall `{}`, which faces \
                         `{name}`: the walls across a sheared wall turn about points on the \
                         wall facing it (a box's side walls: their bottom ends)",
                        walls.walls[side].name, bottom.name
                    ));
                }
            }
        }
        if !stage.glue.is_empty() && strategy == Strategy::Relaxation {
            return Err(InputError::new(
                file,
                "the grain-by-grain solver does not move glued grains with their walls: use \
                 the global solver",
            )
            .at_key(format!("stages[{i}].glue"))
            .into());
        }
    }
    Ok(())
}

/// The centre of a plug of `radius` brought from `center` along the unit direction `moves`
/// to where it first touches one of `grains` (the smallest move, negative when the plug
/// starts inside the grains); `center` itself when no grain lies across its path.
fn touching(center: [f64; 2], radius: f64, moves: [f64; 2], grains: &GrainSet) -> [f64; 2] {
    let first = grains
        .position
        .iter()
        .zip(&grains.radius)
        .filter_map(|(p, r)| {
            let d = [p[0] - center[0], p[1] - center[1]];
            let along = d[0] * moves[0] + d[1] * moves[1];
            let across = d[0] * moves[1] - d[1] * moves[0];
            let reach = radius + r;
            (across.abs() < reach).then(|| along - (reach * reach - across * across).sqrt())
        })
        .min_by(f64::total_cmp);
    match first {
        Some(s) => [center[0] + s * moves[0], center[1] + s * moves[1]],
        None => center,
    }
}

/// The membranes of a scene.
pub fn build_membranes(scene: &Scene) -> Vec<Membrane> {
    scene
        .membranes
        .iter()
        .map(|m| Membrane {
            name: m.name.clone(),
            shape: match (m.side, m.ring) {
                (Some(v), _) => {
                    let len = v[0].hypot(v[1]);
                    MembraneShape::Side {
                        outward: [v[0] / len, v[1] / len],
                    }
                }
                (None, c) => MembraneShape::Ring {
                    center: c.unwrap_or([0.0; 2]),
                },
            },
            pressure: m.pressure,
        })
        .collect()
}

/// The load program with wall and membrane names resolved.
pub fn build_stages(scene: &Scene, walls: &WallSet, membranes: &[Membrane]) -> Vec<StageProgram> {
    let index = |name: &str| walls.walls.iter().position(|w| w.name == name);
    let membrane = |name: &str| membranes.iter().position(|m| m.name == name);
    let mut control: Vec<WallControl> = walls.walls.iter().map(|w| w.control).collect();
    scene
        .stages
        .iter()
        .map(|s| {
            for (name, c) in &s.control {
                if let Some(w) = index(name) {
                    control[w] = *c;
                }
            }
            let mut stage = StageProgram {
                name: s.name.clone(),
                increments: s.increments,
                stress: vec![None; walls.len()],
                normal_move: vec![0.0; walls.len()],
                slide: vec![0.0; walls.len()],
                shear_strain: vec![0.0; walls.len()],
                glue: vec![false; walls.len()],
                pressure: vec![None; membranes.len()],
                control: control.clone(),
                until_failure: s.until_failure,
                failure_drop: s.failure_drop,
                breakouts: s.breakouts,
                until_breakout: s.until_breakout,
            };
            for (name, v) in &s.stress {
                if let Some(w) = index(name) {
                    stage.stress[w] = Some(*v);
                } else if let Some(m) = membrane(name) {
                    stage.pressure[m] = Some(*v);
                }
            }
            for (name, v) in &s.displacement {
                if let Some(w) = index(name) {
                    stage.normal_move[w] = *v;
                }
            }
            for (name, v) in &s.shear {
                if let Some(w) = index(name) {
                    stage.slide[w] = *v;
                }
            }
            for (name, v) in &s.shear_strain {
                if let Some(w) = index(name) {
                    stage.shear_strain[w] = *v;
                }
            }
            for name in &s.glue {
                if let Some(w) = index(name) {
                    stage.glue[w] = true;
                }
            }
            stage
        })
        .collect()
}

/// Grains closer than this fraction of the mean radius count as touching at the start, so a
/// crystal built at exact contact starts with its contacts.
const TOUCH: f64 = 1e-9;

/// The contacts of a fresh sample: every pair touching within a billionth of the mean
/// radius, cemented when the material is bonded (grain-grain contacts only).
pub fn initial_contacts(
    material: &MaterialModel,
    grains: &GrainSet,
    walls: &WallSet,
    skin: f64,
) -> ContactSet {
    let friends = FriendSet::build(grains, walls, skin);
    let tolerance = TOUCH * grains.mean_radius();
    let contacts = friends
        .pairs
        .iter()
        .filter(|p| {
            let gap = match p.a {
                Side::Grain(a) => crate::geometry::gap_between(grains, a, p.b),
                Side::Wall(w) => walls.walls[w].distance(grains.position[p.b]) - grains.radius[p.b],
            };
            gap <= tolerance
        })
        .map(|&p| {
            let bonded = material.bonded && matches!(p.a, Side::Grain(_));
            Contact::new(p, material.params(p, grains, walls), bonded)
        })
        .collect();
    ContactSet {
        contacts,
        broken_bonds: Vec::new(),
    }
}

impl Simulation {
    /// A fresh simulation of `scene` with its grains, solved as `config` says. `file` names the
    /// scene in errors.
    pub fn new(
        scene: &Scene,
        grains: GrainSet,
        config: SolverConfig,
        file: &str,
    ) -> Result<Simulation, Error> {
        if grains.is_empty() {
            return Err(InputError::new(file, "the scene has no grains")
                .at_key("grains")
                .into());
        }
        let walls = build_walls(scene, &grains);
        let material = MaterialModel::from_scene(scene);
        let skin = config.skin * grains.mean_radius();
        let contacts = initial_contacts(&material, &grains, &walls, skin);
        if let Some((key, message)) = crate::scene::start_overlap(scene, &grains, &walls, &contacts)
        {
            return Err(InputError::new(file, message).at_key(key).into());
        }
        Simulation::of_scene(scene, config, grains, walls, contacts, file)
    }

    /// The simulation of `scene` on these grains, walls and contacts: the scene's depth,
    /// membranes and load program.
    fn of_scene(
        scene: &Scene,
        config: SolverConfig,
        grains: GrainSet,
        walls: WallSet,
        contacts: ContactSet,
        file: &str,
    ) -> Result<Simulation, Error> {
        let depth = scene
            .material
            .depth
            .unwrap_or_else(|| 2.0 * grains.mean_radius());
        let membranes = build_membranes(scene);
        let stages = build_stages(scene, &walls, &membranes);
        check_shear_boxes(scene, &walls, config.strategy, file)?;
        let state = State::fresh(grains, walls, contacts, membranes);
        let material = MaterialModel::from_scene(scene);
        let mut sim =
            Simulation::from_state(scene.name.clone(), config, material, depth, stages, state)?;
        sim.regions = scene.regions.iter().map(Region::of_spec).collect();
        Ok(sim)
    }
}

impl Simulation {
    /// A simulation of `scene` starting from the prepared equilibrium of `sample`: the walls
    /// that `[grains] walls` keeps, with the controls it gives them, then the scene's own;
    /// the sample's contacts with their shear forces and bonds, and contacts with the scene's
    /// walls as a fresh scene makes them. `file` names the scene in errors.
    pub fn from_sample(
        scene: &Scene,
        sample: crate::sample::SampleFile,
        config: SolverConfig,
        file: &str,
    ) -> Result<Simulation, Error> {
        let keep = scene.grains.walls.clone().unwrap_or_default();
        let names: Vec<&str> = sample.walls.walls.iter().map(|w| w.name.as_str()).collect();
        if let Some(name) = keep.keys().find(|k| !names.contains(&k.as_str())) {
            return Err(InputError::new(
                file,
                format!(
                    "the sample has no wall `{name}`; its walls are [{}]",
                    names.join(", ")
                ),
            )
            .at_key(format!("grains.walls.{name}"))
            .into());
        }
        let grains = sample.grains;
        if grains.is_empty() {
            return Err(InputError::new(file, "the sample has no grains")
                .at_key("grains.sample")
                .into());
        }
        // The kept walls in the sample's order, then the scene's.
        let mut index = vec![None; sample.walls.len()];
        let mut walls = WallSet::default();
        for (w, wall) in sample.walls.walls.into_iter().enumerate() {
            if let Some(&control) = keep.get(&wall.name) {
                index[w] = Some(walls.len());
                let stress = if control == WallControl::Stress && wall.control != control {
                    sample.stress
                } else {
                    wall.stress
                };
                walls.walls.push(Wall {
                    control,
                    stress,
                    ..wall
                });
            }
        }
        let kept = walls.len();
        walls.walls.extend(build_walls(scene, &grains).walls);

        let material = MaterialModel::from_scene(scene);
        let skin = config.skin * grains.mean_radius();
        let fresh = initial_contacts(&material, &grains, &walls, skin);
        let bonds: std::collections::HashSet<(usize, usize)> =
            sample.bonds.iter().copied().collect();
        let mut contacts: Vec<Contact> = if sample.contacts.is_empty() {
            fresh
                .contacts
                .iter()
                .filter(|c| matches!(c.pair.a, Side::Grain(_)))
                .cloned()
                .collect()
        } else {
            sample
                .contacts
                .iter()
                .filter_map(|h| {
                    let a = match h.pair.a {
                        Side::Wall(w) => Side::Wall(index[w]?),
                        grain => grain,
                    };
                    let pair = Pair { a, b: h.pair.b };
                    let bonded = material.bonded
                        && matches!(a, Side::Grain(i) if bonds.contains(&(i, pair.b)));
                    let mut c = Contact::new(pair, material.params(pair, &grains, &walls), bonded);
                    c.shear_force0 = h.shear_force;
                    c.shear_displacement0 = h.shear_displacement;
                    Some(c)
                })
                .collect()
        };
        contacts.extend(
            fresh
                .contacts
                .into_iter()
                .filter(|c| matches!(c.pair.a, Side::Wall(w) if w >= kept)),
        );
        contacts.sort_by_key(|c| c.pair);

        let contacts = ContactSet {
            contacts,
            broken_bonds: Vec::new(),
        };
        let mut sim = Simulation::of_scene(scene, config, grains, walls, contacts, file)?;
        // The responses of the committed state, for what is measured before the first step.
        sim.equilibrium_error();
        Ok(sim)
    }
}

impl Simulation {
    /// A simulation of `scene` continuing from a state read back from its result file.
    pub fn resume(
        scene: &Scene,
        state: State,
        depth: f64,
        config: SolverConfig,
    ) -> Result<Simulation, Error> {
        let material = MaterialModel::from_scene(scene);
        let stages = build_stages(scene, &state.walls, &state.membranes);
        let mut sim =
            Simulation::from_state(scene.name.clone(), config, material, depth, stages, state)?;
        sim.regions = scene.regions.iter().map(Region::of_spec).collect();
        Ok(sim)
    }
}
