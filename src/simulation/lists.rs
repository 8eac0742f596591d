//! The friends lists of an increment: every pair they hold engaged as a contact, and the
//! lists made anew, with their pattern and the membranes' chains, wherever the grains moved
//! past most of their reach.

use super::{LoadStep, Simulation, REACH_REBUILD};
use crate::contact::{kinematics, Configuration, Contact};
use crate::solver::stats::secs;
use crate::NumericError;
use std::time::Instant;

impl Simulation {
    /// Every pair of the friends lists as a contact of the increment: those already in the
    /// set as they are, the others fresh, with their overlap at the start of the increment
    /// (a pair apart then counts its shear from where its surfaces touch). A contact the
    /// lists no longer hold stays only while it carries or is bonded.
    pub(super) fn engage_pairs(&mut self) {
        let start = Instant::now();
        let rest = Configuration::at_rest(&self.state.grains, &self.state.walls);
        let mut existing = std::mem::take(&mut self.state.contacts.contacts).into_iter();
        let mut next = existing.next();
        let mut engaged = Vec::with_capacity(self.friends.pairs.len());
        let mut outside = Vec::new();
        for &pair in &self.friends.pairs {
            // Contacts before this pair that the lists no longer hold.
            while let Some(c) = next.take_if(|c| c.pair < pair) {
                if c.bonded || c.overlap > 0.0 {
                    outside.push(c);
                }
                next = existing.next();
            }
            if let Some(c) = next.take_if(|c| c.pair == pair) {
                engaged.push(c);
                next = existing.next();
                continue;
            }
            let params = self
                .material
                .params(pair, &self.state.grains, &self.state.walls);
            let mut c = Contact::new(pair, params, false);
            c.start_overlap =
                kinematics(pair, &self.state.grains, &self.state.walls, &rest).overlap;
            c.overlap = c.start_overlap;
            engaged.push(c);
        }
        outside.extend(
            next.into_iter()
                .chain(existing)
                .filter(|c| c.bonded || c.overlap > 0.0),
        );
        if !outside.is_empty() {
            engaged.append(&mut outside);
            engaged.sort_by_key(|c| c.pair);
        }
        self.state.contacts.contacts = engaged;
        self.index_pairs()
            .expect("the friends lists hold every contact that carries");
        self.stats.timers.topology += secs(start);
    }

    /// Make the friends lists anew around the grains and walls at `u` when something moved
    /// past most of their reach.
    pub(super) fn renew_lists_if_far(
        &mut self,
        step: &LoadStep,
        u: &[f64],
    ) -> Result<(), NumericError> {
        self.equations(step).configure(u);
        let wall_turn: Vec<f64> = (self.state.walls.walls.iter().zip(&step.turn))
            .map(|(w, t)| w.turn + t)
            .collect();
        let drift = self
            .friends
            .drift(&self.q.position, &self.q.wall_position, &wall_turn);
        if drift > REACH_REBUILD * 0.5 * self.friends.skin {
            self.renew_lists(step, u)?;
        }
        Ok(())
    }

    /// The friends lists made anew around the grains and walls at `u`, with their pattern,
    /// the membranes' chains where the grains are, and every new pair engaged.
    pub(super) fn renew_lists(&mut self, step: &LoadStep, u: &[f64]) -> Result<(), NumericError> {
        self.equations(step).configure(u);
        let mut grains = self.state.grains.clone();
        grains.position.clone_from(&self.q.position);
        let mut walls = self.state.walls.clone();
        for (w, wall) in walls.walls.iter_mut().enumerate() {
            wall.position = self.q.wall_position[w];
            wall.slide += step.slide[w];
            wall.turn += step.turn[w];
        }
        let carrying: Vec<_> = self
            .state
            .contacts
            .contacts
            .iter()
            .filter(|c| c.bonded || c.overlap > 0.0)
            .map(|c| c.pair)
            .collect();
        self.make_friends(&grains, &walls, &carrying);
        self.engage_pairs();
        self.install_pattern()?;
        self.refresh_chains(true)?;
        Ok(())
    }
}
