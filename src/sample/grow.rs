//! Growing a sprinkled sample (thesis 2.2, phase 1; 3.2.1): the grains, placed at a fraction
//! of their size, are blown up to full size while the stress-controlled walls hold the
//! target isotropic stress, with the grain friction lowered to `f_gg'` so that the density
//! can be set. Growth rearranges grains over many diameters, which has no nearby equilibrium
//! to solve for; it runs as explicit dynamics on the same contact laws (as PFC and Yade grow
//! samples), relaxed by FIRE (Bitzek et al. 2006), which brings a jammed packing to rest far
//! faster than viscous or local damping. The quasi-static solver then takes the packing to
//! exact equilibrium ([`super::prepare`]).
//!
//! Masses are scaled (all equal, set by the contact stiffness so that a time step of one is
//! stable): only the state at rest matters.

use crate::geometry::{FriendSet, GrainSet, Pair, Side, WallControl, WallSet};
use crate::simulation::MaterialModel;

/// How the growth runs.
#[derive(Debug, Clone, PartialEq)]
pub struct GrowSettings {
    /// Grain-grain friction while growing, `f_gg'`.
    pub friction: f64,
    /// Stress the stress-controlled walls hold (Pa).
    pub stress: f64,
    /// Explicit steps over which the radii grow to full size.
    pub growth_steps: usize,
    /// Explicit steps allowed afterwards to come to rest.
    pub max_rest_steps: usize,
    /// Steps without a new quietest state after which the rest phase gives up and hands the
    /// quietest state on: a large packing under stress-controlled walls keeps rearranging in
    /// small avalanches long after it is near rest.
    pub patience: usize,
    /// At rest: mean unbalanced force below this fraction of the mean contact force, and the
    /// wall stresses within it of the target.
    pub rest: f64,
}

impl Default for GrowSettings {
    fn default() -> Self {
        GrowSettings {
            friction: 0.0,
            stress: 1e5,
            growth_steps: 4000,
            max_rest_steps: 20000,
            patience: 4000,
            rest: 1e-5,
        }
    }
}

/// How the growth went.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GrowReport {
    /// Explicit steps taken.
    pub steps: usize,
    /// Mean unbalanced force over the mean contact force in the state handed on.
    pub unbalanced: f64,
    /// Largest relative deviation of a stress-controlled wall from the target in that state.
    pub wall_error: f64,
    /// Whether the rest criterion was met.
    pub at_rest: bool,
}

/// The shear force of every touching pair at the end of growth: a frictional packing at rest
/// stands on them, so the quasi-static solver starts from them.
pub type ShearForces = Vec<(Pair, f64)>;

/// Grow `grains` (sprinkled positions, full radii) from `start` times their size to full
/// size inside `walls`, then let them come to rest. The grains keep their radii and get the
/// positions of the state at rest, or of the quietest full-size state seen when rest is not
/// reached; the walls their positions. `progress` sees (step, steps planned).
/// Returns how it went and the shear force of every touching pair.
pub fn grow(
    grains: &mut GrainSet,
    walls: &mut WallSet,
    material: &MaterialModel,
    depth: f64,
    start: f64,
    settings: &GrowSettings,
    mut progress: impl FnMut(usize, usize),
) -> (GrowReport, ShearForces) {
    let n = grains.len();
    let law = material.law();
    let prep = MaterialModel {
        friction: settings.friction,
        ..material.clone()
    };
    let full = grains.radius.clone();
    let r_mean = grains.mean_radius();
    // A contact force of the target stress on a grain, and the stiffness it brings.
    let force = settings.stress * 2.0 * r_mean * depth;
    let k = material.stiffness_at(r_mean, force);
    let mass = 36.0 * k;
    // Rotational inertia five times a disc's: a shear spring moves both grains and turns
    // both, and with a disc's inertia the shear mode of a grain with six contacts would be
    // unstable at FIRE's longest step.
    let inertia: Vec<f64> = full.iter().map(|r| 2.5 * mass * r * r).collect();

    let mut now = grains.clone();
    let mut velocity = vec![[0.0f64; 2]; n];
    let mut spin = vec![0.0f64; n];
    let mut wall_speed = vec![0.0f64; walls.len()];
    let wall_mass: Vec<f64> = (0..walls.len())
        .map(|w| mass * walls.length(w).unwrap_or(2.0 * r_mean) / (2.0 * r_mean))
        .collect();

    let skin = 0.5 * r_mean;
    let r_max = full.iter().cloned().fold(0.0, f64::max);
    let mut friends = FriendSet::build(&now, walls, skin);
    let mut shear = vec![0.0f64; friends.pairs.len()];
    let mut radius_at_build = start;
    let planned = settings.growth_steps + settings.max_rest_steps;
    let mut fire = Fire::default();
    let mut report = GrowReport::default();
    let mut quietest: Option<Snapshot> = None;

    for step in 0..planned {
        let scale =
            (start + (1.0 - start) * step as f64 / settings.growth_steps.max(1) as f64).min(1.0);
        for (r, f) in now.radius.iter_mut().zip(&full) {
            *r = scale * f;
        }
        // Friends lists: rebuilt once something moved, or two of the largest grains grew
        // towards each other, by half the skin.
        let grown = (scale - radius_at_build) * 2.0 * r_max;
        let wall_position: Vec<f64> = walls.walls.iter().map(|w| w.position).collect();
        let wall_turn: Vec<f64> = walls.walls.iter().map(|w| w.turn).collect();
        if grown > 0.5 * skin || friends.is_stale(&now.position, &wall_position, &wall_turn) {
            let old = std::mem::replace(&mut friends, FriendSet::build(&now, walls, skin));
            shear = friends
                .pairs
                .iter()
                .map(|p| old.pairs.binary_search(p).map_or(0.0, |i| shear[i]))
                .collect();
            radius_at_build = scale;
        }

        // Contact forces, with the shear force carried from step to step.
        let lengths: Vec<Option<f64>> = (0..walls.len()).map(|w| walls.length(w)).collect();
        let mut force_on = vec![[0.0f64; 2]; n];
        let mut moment = vec![0.0f64; n];
        let mut wall_force = vec![0.0f64; walls.len()];
        let (mut sum_fn, mut contacts) = (0.0, 0usize);
        for (k_pair, pair) in friends.pairs.iter().enumerate() {
            let Some(c) = contact(*pair, &now, walls, &velocity, &spin, fire.dt) else {
                shear[k_pair] = 0.0;
                continue;
            };
            let params = prep.params(*pair, &now, walls);
            let response = law.respond(&params, false, c.overlap, shear[k_pair], c.slip);
            shear[k_pair] = response.shear_force;
            let (fn_, fs) = (response.normal_force, response.shear_force);
            let on_b = [
                fn_ * c.normal[0] - fs * c.tangent[0],
                fn_ * c.normal[1] - fs * c.tangent[1],
            ];
            let b = pair.b;
            force_on[b][0] += on_b[0];
            force_on[b][1] += on_b[1];
            moment[b] += now.radius[b] * fs;
            match pair.a {
                Side::Grain(a) => {
                    force_on[a][0] -= on_b[0];
                    force_on[a][1] -= on_b[1];
                    moment[a] += now.radius[a] * fs;
                }
                Side::Wall(w) => wall_force[w] += fn_,
            }
            sum_fn += fn_.abs();
            contacts += 1;
        }

        // Net forces on every grain and every stress-controlled wall.
        let mut unbalanced = 0.0;
        for f in &force_on {
            unbalanced += f[0].abs() + f[1].abs();
        }
        let mut wall_error = 0.0f64;
        let mut wall_net = vec![0.0f64; walls.len()];
        for (w, wall) in walls.walls.iter_mut().enumerate() {
            let (WallControl::Stress, Some(length)) = (wall.control, lengths[w]) else {
                continue;
            };
            wall.stress = settings.stress;
            let load = settings.stress * length * depth;
            wall_net[w] = load - wall_force[w];
            wall_error = wall_error.max((wall_net[w] / load).abs());
        }

        // FIRE: while the power F.v is positive the velocity turns towards the force and the
        // step grows; when it turns negative everything stops and starts again carefully.
        let power: f64 = (0..n)
            .map(|i| {
                force_on[i][0] * velocity[i][0]
                    + force_on[i][1] * velocity[i][1]
                    + moment[i] * spin[i]
            })
            .sum::<f64>()
            + (0..walls.len())
                .map(|w| wall_net[w] * wall_speed[w])
                .sum::<f64>();
        if power > 0.0 {
            // Mix in mass-weighted form, so translations, rotations and walls share one norm.
            let (mut vv, mut ff) = (0.0, 0.0);
            for i in 0..n {
                vv += mass * (velocity[i][0].powi(2) + velocity[i][1].powi(2))
                    + inertia[i] * spin[i].powi(2);
                ff += (force_on[i][0].powi(2) + force_on[i][1].powi(2)) / mass
                    + moment[i].powi(2) / inertia[i];
            }
            for w in 0..walls.len() {
                vv += wall_mass[w] * wall_speed[w].powi(2);
                ff += wall_net[w].powi(2) / wall_mass[w];
            }
            let ratio = if ff > 0.0 { (vv / ff).sqrt() } else { 0.0 };
            for i in 0..n {
                for d in 0..2 {
                    velocity[i][d] = (1.0 - fire.alpha) * velocity[i][d]
                        + fire.alpha * ratio * force_on[i][d] / mass;
                }
                spin[i] =
                    (1.0 - fire.alpha) * spin[i] + fire.alpha * ratio * moment[i] / inertia[i];
            }
            for w in 0..walls.len() {
                wall_speed[w] = (1.0 - fire.alpha) * wall_speed[w]
                    + fire.alpha * ratio * wall_net[w] / wall_mass[w];
            }
            fire.positive += 1;
            if fire.positive > FIRE_DELAY {
                fire.dt = (fire.dt * 1.1).min(FIRE_DT_MAX);
                fire.alpha *= 0.99;
            }
        } else {
            fire = Fire {
                dt: fire.dt * 0.5,
                ..Fire::default()
            };
            velocity.iter_mut().for_each(|v| *v = [0.0; 2]);
            spin.iter_mut().for_each(|w| *w = 0.0);
            wall_speed.iter_mut().for_each(|v| *v = 0.0);
        }
        let dt = fire.dt;
        for i in 0..n {
            for d in 0..2 {
                velocity[i][d] += dt * force_on[i][d] / mass;
                now.position[i][d] += dt * velocity[i][d];
            }
            spin[i] += dt * moment[i] / inertia[i];
            now.rotation[i] += dt * spin[i];
        }
        for (w, wall) in walls.walls.iter_mut().enumerate() {
            if wall.control == WallControl::Stress {
                wall_speed[w] += dt * wall_net[w] / wall_mass[w];
                wall.position += dt * wall_speed[w];
            }
        }

        report.steps = step + 1;
        report.unbalanced = if sum_fn > 0.0 {
            (unbalanced / n as f64) / (sum_fn / contacts as f64)
        } else {
            f64::INFINITY
        };
        report.wall_error = wall_error;
        if step % 50 == 0 {
            progress(step, planned);
        }
        if scale < 1.0 {
            continue;
        }
        if report.unbalanced < settings.rest && wall_error < settings.rest {
            report.at_rest = true;
            break;
        }
        let quiet = report.unbalanced.max(wall_error);
        match &quietest {
            Some(q) if q.quiet <= quiet => {
                if step - q.step > settings.patience {
                    break;
                }
            }
            _ => {
                quietest = Some(Snapshot {
                    step,
                    quiet,
                    report,
                    position: now.position.clone(),
                    wall_position: walls.walls.iter().map(|w| w.position).collect(),
                    shear: shear_forces(&friends, &shear),
                })
            }
        }
    }
    progress(planned, planned);
    let mut shear_now = shear_forces(&friends, &shear);
    if let Some(q) = quietest.filter(|_| !report.at_rest) {
        now.position = q.position;
        for (wall, position) in walls.walls.iter_mut().zip(q.wall_position) {
            wall.position = position;
        }
        shear_now = q.shear;
        report = GrowReport {
            steps: report.steps,
            ..q.report
        };
    }
    *grains = GrainSet::new(now.position, full);
    (report, shear_now)
}

/// The quietest full-size state seen, handed on when the packing does not come to rest.
struct Snapshot {
    step: usize,
    /// The larger of the unbalanced force and the wall error.
    quiet: f64,
    report: GrowReport,
    position: Vec<[f64; 2]>,
    wall_position: Vec<f64>,
    shear: ShearForces,
}

/// The shear force of every pair that carries one.
fn shear_forces(friends: &FriendSet, shear: &[f64]) -> ShearForces {
    friends
        .pairs
        .iter()
        .zip(shear)
        .filter(|(_, f)| **f != 0.0)
        .map(|(p, f)| (*p, *f))
        .collect()
}

/// Steps of positive power before FIRE lengthens its step.
const FIRE_DELAY: usize = 5;
/// Longest FIRE step, in units of the step a single contact allows.
const FIRE_DT_MAX: f64 = 2.5;

/// FIRE's state: the step and the mixing factor, and how long the power has been positive.
#[derive(Debug, Clone, Copy)]
struct Fire {
    dt: f64,
    alpha: f64,
    positive: usize,
}

impl Default for Fire {
    fn default() -> Self {
        Fire {
            dt: 1.0,
            alpha: 0.1,
            positive: 0,
        }
    }
}

/// Geometry of a touching pair in the current step: `None` when apart.
struct Touch {
    normal: [f64; 2],
    tangent: [f64; 2],
    overlap: f64,
    /// Shear displacement of this step.
    slip: f64,
}

/// The touch of `pair`, its shear displacement that of a step `dt` at the current velocities.
fn contact(
    pair: Pair,
    grains: &GrainSet,
    walls: &WallSet,
    velocity: &[[f64; 2]],
    spin: &[f64],
    dt: f64,
) -> Option<Touch> {
    let b = pair.b;
    let (xb, rb) = (grains.position[b], grains.radius[b]);
    match pair.a {
        Side::Grain(a) => {
            let (xa, ra) = (grains.position[a], grains.radius[a]);
            let d = [xb[0] - xa[0], xb[1] - xa[1]];
            let len = d[0].hypot(d[1]);
            let overlap = ra + rb - len;
            if overlap <= 0.0 {
                return None;
            }
            let n = [d[0] / len, d[1] / len];
            let t = [-n[1], n[0]];
            let dv = [
                velocity[b][0] - velocity[a][0],
                velocity[b][1] - velocity[a][1],
            ];
            Some(Touch {
                normal: n,
                tangent: t,
                overlap,
                slip: dt * (dv[0] * t[0] + dv[1] * t[1] - ra * spin[a] - rb * spin[b]),
            })
        }
        Side::Wall(w) => {
            let wall = &walls.walls[w];
            let overlap = rb - wall.distance(xb);
            if overlap <= 0.0 {
                return None;
            }
            let n = match &wall.circle {
                Some(c) => {
                    let center = c.center_at(wall.position);
                    let d = [xb[0] - center[0], xb[1] - center[1]];
                    let len = d[0].hypot(d[1]);
                    let e = [d[0] / len, d[1] / len];
                    if c.grains_inside {
                        [-e[0], -e[1]]
                    } else {
                        e
                    }
                }
                None => wall.normal,
            };
            let t = [-n[1], n[0]];
            Some(Touch {
                normal: n,
                tangent: t,
                overlap,
                slip: dt * (velocity[b][0] * t[0] + velocity[b][1] * t[1] - rb * spin[b]),
            })
        }
    }
}
