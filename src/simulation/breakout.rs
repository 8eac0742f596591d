//! Taking a cluster of grains out of a running simulation: the grains that broke out of the
//! sample (the borehole's surface of the cylinder test, thesis 4.4.2), which no equilibrium
//! holds any more, or which came loose from it and are free to fall into the borehole. They
//! keep their rows in every per-grain array, so grain indices never change; from then on
//! they touch nothing and carry nothing, their unknowns are held where they were taken out,
//! and no measurement counts them.

use super::{anchors, chains, energy, membrane_carriers, Simulation};
use crate::contact::{BreakMode, BrokenBond, ContactSet};
use crate::geometry::{Side, WallControl};
use crate::state::{Breakout, IncrementReport};
use crate::NumericError;

/// How far, in its largest diameters, a cluster that touches nothing of the sample must be
/// free to move towards the borehole's centre to count as broken out: a grain loose in a
/// pore is caged closer than that.
const FREE_PATH: f64 = 1.0;

impl Simulation {
    /// Take `grains` out of the sample, and record it as a breakout in the state.
    ///
    /// The increment solver takes a cluster out where its step finds no equilibrium near
    /// because the cluster is carried on and on (`remove_cluster`, then it goes
    /// on from the step's last equilibrium); this takes one out of the committed state, as
    /// between increments, for the next one to go on without it. The breakout belongs to the
    /// increment being solved (the committed one plus one), and records the loads of the
    /// committed state: the last the sample carried in equilibrium with the cluster in it.
    ///
    /// The grains' contacts go: an intact bond with a grain left in the sample breaks (in
    /// tension, recorded in `broken_bonds` and counted in the breakout's `bonds_broken`,
    /// which the caller adds to its increment's report), bonds within the cluster go with
    /// it. Their unknowns are held at zero from then on ([`crate::assembly::DofMap::grain_held`]),
    /// so they stay where they are; they have no friends, anchor nothing and carry no
    /// membrane. The energy their contacts stored is counted as carried away in this
    /// increment's balance ([`crate::simulation::EnergyBalance::taken_out`]). The friends
    /// lists, the pattern and its symbolic factorisation are made anew around the committed
    /// state, as a run resumed from it would make them, so a resumed run that takes the
    /// same grains out goes on as the uninterrupted one.
    ///
    /// # Panics
    ///
    /// If `grains` is empty, or names a grain that does not exist or is already taken out:
    /// the caller names grains of the sample.
    pub fn take_out(&mut self, grains: &[usize]) -> Result<Breakout, NumericError> {
        let breakout = self.remove_cluster(grains);
        self.rebuild_workspace()?;
        Ok(breakout)
    }

    /// Take `grains` out of the state and record the breakout, as [`Simulation::take_out`]
    /// does, leaving the unknowns, friends lists and pattern to the caller: within a step
    /// they are made anew around its iterate, not the committed state.
    pub(super) fn remove_cluster(&mut self, grains: &[usize]) -> Breakout {
        let n = self.state.grains.len();
        let mut cluster = grains.to_vec();
        cluster.sort_unstable();
        cluster.dedup();
        assert!(!cluster.is_empty(), "take_out: no grains named");
        for &g in &cluster {
            assert!(
                g < n && !self.state.grains.taken_out[g],
                "take_out: grain {g} is not in the sample"
            );
            self.state.grains.taken_out[g] = true;
        }
        let increment = self.state.increment + 1;
        let debris = self.is_debris(&cluster);
        let out = &self.state.grains.taken_out;
        let law = self.law.as_ref();
        let ContactSet {
            contacts,
            broken_bonds,
        } = &mut *self.state.contacts;
        let (mut bonds_broken, mut carried_away) = (0, 0.0);
        contacts.retain(|c| {
            let a_out = matches!(c.pair.a, Side::Grain(a) if out[a]);
            if !a_out && !out[c.pair.b] {
                return true;
            }
            // A bond across the cluster's edge (a wall's bond is glue, not cement).
            if c.bonded && matches!(c.pair.a, Side::Grain(_)) && a_out != out[c.pair.b] {
                broken_bonds.push(BrokenBond {
                    pair: c.pair,
                    increment,
                    mode: BreakMode::Tension,
                });
                bonds_broken += 1;
            }
            carried_away += energy::stored_energy(law, c);
            false
        });
        self.energy.taken_out += carried_away;
        self.stats.counters.bonds_broken += bonds_broken;
        // Held where they are: a predictor would move them.
        let per = self.dofs.per_grain;
        if self.state.last_step.len() == self.dofs.len {
            for &g in &cluster {
                self.state.last_step[g * per..(g + 1) * per].fill(0.0);
            }
        }
        let breakout = Breakout {
            increment,
            grains: cluster,
            bonds_broken,
            debris,
            pressure: self.state.membranes.iter().map(|m| m.pressure).collect(),
            stress: (self.state.walls.walls.iter())
                .map(|w| (w.control == WallControl::Stress).then_some(w.stress))
                .collect(),
        };
        self.state.breakouts.push(breakout.clone());
        breakout
    }

    /// Whether `cluster` is debris ([`Breakout::debris`]): none of its grains ever cemented,
    /// none touching or glued to anything (a grain or a wall) where the increment started.
    fn is_debris(&self, cluster: &[usize]) -> bool {
        let cemented = self.cemented_once();
        let touched = (self.state.contacts.contacts.iter())
            .filter(|c| c.start_overlap > 0.0 || c.bonded)
            .any(|c| {
                matches!(c.pair.a, Side::Grain(a) if cluster.binary_search(&a).is_ok())
                    || cluster.binary_search(&c.pair.b).is_ok()
            });
        !touched && !cluster.iter().any(|&g| cemented[g])
    }

    /// Each grain's: whether it was ever cemented, a bond of it intact or broken.
    fn cemented_once(&self) -> Vec<bool> {
        let mut cemented = vec![false; self.state.grains.len()];
        let ContactSet {
            contacts,
            broken_bonds,
        } = &*self.state.contacts;
        let pairs = (contacts.iter())
            .filter(|c| c.bonded || c.broken)
            .map(|c| c.pair)
            .chain(broken_bonds.iter().map(|b| b.pair));
        for pair in pairs {
            if let Side::Grain(a) = pair.a {
                (cemented[a], cemented[pair.b]) = (true, true);
            }
        }
        cemented
    }

    /// Take out, in a stage that takes breakouts out, each cluster of the committed state that
    /// has come loose from the sample at the borehole: grains joined by bonds or touching
    /// contacts, none of them to the body of the sample (its largest such cluster), at least
    /// one of them cemented once (a rattler of the prepared sample never broke out of
    /// anything), and free to move [`FREE_PATH`] of its largest diameter towards the centre
    /// of the sample (the borehole's) without touching it. Such a cluster carries nothing,
    /// so the equilibrium of the rest holds without it. Its breakout is recorded at the loads
    /// just committed.
    pub(super) fn take_out_detached(
        &mut self,
        report: &mut IncrementReport,
    ) -> Result<(), NumericError> {
        if !self.stages[self.state.stage].breakouts {
            return Ok(());
        }
        let clusters = self.detached_clusters();
        if clusters.is_empty() {
            return Ok(());
        }
        for cluster in &clusters {
            report.bonds_broken += self.remove_cluster(cluster).bonds_broken;
        }
        self.rebuild_workspace()
    }

    /// The clusters [`Simulation::take_out_detached`] takes out, each in increasing order.
    fn detached_clusters(&self) -> Vec<Vec<usize>> {
        let grains = &self.state.grains;
        let n = grains.len();
        // Clusters by bonds and touching contacts, each grain's by its smallest member.
        let mut root: Vec<usize> = (0..n).collect();
        fn find(root: &mut [usize], mut g: usize) -> usize {
            while root[g] != g {
                root[g] = root[root[g]];
                g = root[g];
            }
            g
        }
        let cemented = self.cemented_once();
        for c in &self.state.contacts.contacts {
            let Side::Grain(a) = c.pair.a else { continue };
            if c.bonded || c.overlap > 0.0 {
                let (ra, rb) = (find(&mut root, a), find(&mut root, c.pair.b));
                root[ra.max(rb)] = ra.min(rb);
            }
        }
        let root: Vec<usize> = (0..n).map(|g| find(&mut root, g)).collect();
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); n];
        for g in grains.in_sample() {
            members[root[g]].push(g);
        }
        let Some(body) = (0..n).max_by_key(|&r| (members[r].len(), std::cmp::Reverse(r))) else {
            return Vec::new();
        };
        let in_sample: Vec<usize> = grains.in_sample().collect();
        let count = in_sample.len() as f64;
        let centre = in_sample.iter().fold([0.0; 2], |s, &g| {
            let p = grains.position[g];
            [s[0] + p[0] / count, s[1] + p[1] / count]
        });
        members
            .into_iter()
            .enumerate()
            .filter(|(r, cluster)| *r != body && !cluster.is_empty())
            .map(|(_, cluster)| cluster)
            .filter(|cluster| cluster.iter().any(|&g| cemented[g]) && self.breaks_out(cluster))
            .filter(|cluster| self.free_towards(cluster, centre, &root, body))
            .collect()
    }

    /// Whether `cluster` can move [`FREE_PATH`] of its largest diameter towards `centre`
    /// without touching a grain of the cluster `body` (`root` each grain's cluster).
    fn free_towards(
        &self,
        cluster: &[usize],
        centre: [f64; 2],
        root: &[usize],
        body: usize,
    ) -> bool {
        let grains = &self.state.grains;
        let count = cluster.len() as f64;
        let middle = cluster.iter().fold([0.0; 2], |s, &g| {
            let p = grains.position[g];
            [s[0] + p[0] / count, s[1] + p[1] / count]
        });
        let towards = [centre[0] - middle[0], centre[1] - middle[1]];
        let length = towards[0].hypot(towards[1]);
        if length == 0.0 {
            return false;
        }
        let e = [towards[0] / length, towards[1] / length];
        let largest = cluster
            .iter()
            .map(|&g| grains.radius[g])
            .fold(0.0, f64::max);
        let path = FREE_PATH * 2.0 * largest;
        cluster.iter().all(|&g| {
            let (p, r) = (grains.position[g], grains.radius[g]);
            grains.in_sample().filter(|&h| root[h] == body).all(|h| {
                // The nearest point of the path from `p` to `p + path e` to the other centre.
                let c = grains.position[h];
                let along = ((c[0] - p[0]) * e[0] + (c[1] - p[1]) * e[1]).clamp(0.0, path);
                let nearest = [p[0] + along * e[0], p[1] + along * e[1]];
                let gap = (c[0] - nearest[0]).hypot(c[1] - nearest[1]);
                gap >= r + grains.radius[h]
            })
        })
    }

    /// The unknowns, membrane carriers and chains, anchors, friends lists and pattern of the
    /// committed state, made anew.
    pub(super) fn rebuild_workspace(&mut self) -> Result<(), NumericError> {
        let state = &self.state;
        self.dofs = super::dof_map(state, self.material.fixed_rotations);
        self.carriers = membrane_carriers(&state.grains, &state.contacts.contacts);
        self.chains = chains(
            &state.membranes,
            &state.grains.position,
            &state.grains.radius,
            &self.carriers,
            &state.grains.taken_out,
        );
        self.anchors = anchors(&state.grains, &state.walls, &state.contacts.contacts);
        self.linear.invalidate();
        let (grains, walls) = (state.grains.clone(), state.walls.clone());
        self.rebuild_friends(&grains, &walls)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples;
    use crate::scene::build_grains;
    use crate::simulation::tests::simulation_of;
    use crate::solver::{SolverConfig, Strategy};
    use std::path::Path;

    /// Three grains of the top row of a cemented crystal in a box, touching the
    /// stress-controlled top wall, taken out after the isotropic stage: their contacts with the
    /// wall and the crystal go, and the biaxial stage solves on without them, by each strategy
    /// (each holds their unknowns its own way; the relaxation's sweeps stop short of the
    /// tolerance by design).
    #[test]
    fn a_cluster_at_a_wall_comes_out_and_the_rest_solves() {
        for strategy in [Strategy::Minimise, Strategy::Relaxation] {
            let scene = samples::crystal_biaxial(9, 8, 1e6, 3e6);
            let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
            let config = SolverConfig {
                strategy,
                ..SolverConfig::default()
            };
            let mut sim = Simulation::new(&scene, grains, config, "t").unwrap();
            for _ in 0..2 {
                sim.run_increment().unwrap();
            }
            let g = &sim.state.grains;
            let top = g.position.iter().map(|p| p[1]).fold(f64::MIN, f64::max);
            let near_top = |i: usize| g.position[i][1] > top - g.radius[i];
            let mut row: Vec<usize> = (0..g.len()).filter(|&i| near_top(i)).collect();
            row.sort_by(|&a, &b| g.position[a][0].total_cmp(&g.position[b][0]));
            let cluster = row[row.len() / 2 - 1..row.len() / 2 + 2].to_vec();
            let before = sim.state.grains.clone();
            let breakout = sim.take_out(&cluster).unwrap();
            // Walls: bottom and left held, right and top at the isotropic stage's 1 MPa.
            assert_eq!(breakout.stress, [None, Some(1e6), Some(1e6), None]);
            assert!(breakout.bonds_broken > 0);
            while !sim.is_finished() {
                sim.run_increment()
                    .unwrap_or_else(|e| panic!("{strategy:?}: {e}"));
            }
            for &i in &cluster {
                assert_eq!(sim.state.grains.position[i], before.position[i]);
                assert_eq!(sim.state.grains.rotation[i], before.rotation[i]);
            }
            let touches = |c: &crate::contact::Contact| {
                cluster.contains(&c.pair.b)
                    || matches!(c.pair.a, Side::Grain(a) if cluster.contains(&a))
            };
            assert!(!sim.state.contacts.contacts.iter().any(touches));
            let (error, grain) = sim.equilibrium_error();
            if strategy != Strategy::Relaxation {
                assert!(
                    error < 1e-6,
                    "{strategy:?}: imbalance {error:e} at grain {grain}"
                );
            }
        }
    }

    /// A grain never cemented that touches nothing where the increment starts comes out as
    /// debris; one cemented to another does not, nor does a cluster of it and a rattler.
    #[test]
    fn a_rattler_comes_out_as_debris() {
        let new = || {
            simulation_of(
                r#"
name = "rattler"
[material]
law = "linear"
normal_stiffness = 1e6
bonded = true
[grains]
x = [0.0, 2e-4, 1e-3, 5e-4, 7.1e-4]
y = [0.0, 0.0, 0.0, 5e-4, 5e-4]
r = [1e-4, 1e-4, 1e-4, 1e-4, 1e-4]
[box]
[[stages]]
increments = 1
"#,
            )
        };
        let sim = new();
        let bonded = |g: usize| {
            let c = &sim.state.contacts.contacts;
            c.iter()
                .any(|c| c.bonded && (c.pair.b == g || c.pair.a == Side::Grain(g)))
        };
        // 0 and 1 touch and are cemented; 2 touches nothing; 3 and 4 are a hair apart.
        assert!(bonded(0) && bonded(1) && !bonded(2) && !bonded(3));
        for (cluster, debris) in [
            (vec![2], true),
            (vec![3], true),
            (vec![0], false),
            (vec![1, 2], false),
        ] {
            let mut sim = new();
            assert_eq!(
                sim.take_out(&cluster).unwrap().debris,
                debris,
                "{cluster:?}"
            );
        }
    }

    /// The clusters that break out in one increment are counted together: one that alone is
    /// within the share breaks out no more once those before it in the increment fill it,
    /// and does again in the next increment.
    #[test]
    fn breakouts_of_one_increment_count_together_against_the_share() {
        let mut scene = samples::crystal_biaxial(9, 8, 1e6, 3e6);
        scene.stages[1].breakouts = true;
        let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
        let mut sim = Simulation::new(&scene, grains, SolverConfig::default(), "t").unwrap();
        while sim.state.stage == 0 {
            sim.run_increment().unwrap();
        }
        let n = sim.state.grains.in_sample().count();
        let share = (super::super::increment::BREAKOUT_SHARE * n as f64).floor() as usize;
        let first: Vec<usize> = (0..share - 2).collect();
        let second: Vec<usize> = (share..share + 3).collect();
        assert!(sim.breaks_out(&first) && sim.breaks_out(&second));
        sim.take_out(&first).unwrap();
        assert!(
            !sim.breaks_out(&second),
            "{} + {} of {n}",
            first.len(),
            second.len()
        );
        sim.run_increment().unwrap();
        assert!(sim.breaks_out(&second));
    }
}
