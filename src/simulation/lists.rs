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
    /// lists no longer hold stays only while it carries or is bonded. The set is merged with
    /// the lists in its own vector (both are in the pairs' order): a second vector of the
    /// contacts filled beside it was part of a million-grain run's peak (670 MB).
    pub(super) fn engage_pairs(&mut self) {
        let start = Instant::now();
        let rest = Configuration::at_rest(&self.state.grains, &self.state.walls);
        let friends = &self.friends.pairs;
        let contacts = &mut self.state.contacts.contacts;
        let mut f = 0;
        contacts.retain(|c| {
            while f < friends.len() && friends[f] < c.pair {
                f += 1;
            }
            friends.get(f) == Some(&c.pair) || c.bonded || c.overlap > 0.0
        });
        let mut fresh = Vec::new();
        let mut k = 0;
        for &pair in friends {
            while k < contacts.len() && contacts[k].pair < pair {
                k += 1;
            }
            if contacts.get(k).is_some_and(|c| c.pair == pair) {
                continue;
            }
            let params = self
                .material
                .params(pair, &self.state.grains, &self.state.walls);
            let mut c = Contact::new(pair, params, false);
            c.start_overlap =
                kinematics(pair, &self.state.grains, &self.state.walls, &rest).overlap;
            c.overlap = c.start_overlap;
            fresh.push(c);
        }
        // The fresh contacts merged in from the back: the slots past the kept ones are
        // written last to first, each contact moving once.
        let kept = contacts.len();
        contacts.reserve_exact(fresh.len());
        contacts.extend(fresh.iter().cloned());
        let (mut unread, mut unwritten) = (kept, contacts.len());
        for c in fresh.into_iter().rev() {
            while unread > 0 && contacts[unread - 1].pair > c.pair {
                contacts.swap(unread - 1, unwritten - 1);
                (unread, unwritten) = (unread - 1, unwritten - 1);
            }
            contacts[unwritten - 1] = c;
            unwritten -= 1;
        }
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
