//! Taking a cluster of grains out of a running simulation: the grains that broke out of the
//! sample (the borehole's surface of the cylinder test, thesis 4.4.2), which no equilibrium
//! holds any more. They keep their rows in every per-grain array, so grain indices never
//! change; from then on they touch nothing and carry nothing, their unknowns are held where
//! they were taken out, and no measurement counts them.

use super::{anchors, chains, energy, membrane_carriers, Simulation};
use crate::contact::{BreakMode, BrokenBond, ContactSet};
use crate::geometry::{Side, WallControl};
use crate::state::Breakout;
use crate::NumericError;

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
        let out = &self.state.grains.taken_out;
        let law = self.law.as_ref();
        let ContactSet {
            contacts,
            broken_bonds,
        } = &mut self.state.contacts;
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
            pressure: self.state.membranes.iter().map(|m| m.pressure).collect(),
            stress: (self.state.walls.walls.iter())
                .map(|w| (w.control == WallControl::Stress).then_some(w.stress))
                .collect(),
        };
        self.state.breakouts.push(breakout.clone());
        breakout
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
}
