//! Bonds broken one at a time (method note, step 5): the bond most past its strength breaks
//! at each equilibrium, and a step whose end has one past its strength is cut where the
//! first bond's margin crosses zero, so that it breaks within a bracket of its load.

use super::Simulation;
use crate::contact::{BrokenBond, ContactSet};

impl Simulation {
    /// Break the bond most past its strength, if any (method note, step 5): the one whose
    /// force is the largest multiple of what it can carry. Returns whether one broke.
    pub(super) fn break_most_overloaded_bond(&mut self) -> bool {
        let set = &mut *self.state.contacts;
        let worst = set
            .contacts
            .iter()
            .enumerate()
            .filter_map(|(i, c)| c.bond_overload().map(|(ratio, mode)| (i, ratio, mode)))
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)));
        let Some((i, _, mode)) = worst else {
            return false;
        };
        let c = &mut set.contacts[i];
        self.energy.bonds_released += super::energy::bond_energy(self.law.as_ref(), c);
        c.bonded = false;
        c.broken = true;
        set.broken_bonds.push(BrokenBond {
            pair: c.pair,
            increment: self.state.increment + 1,
            mode,
        });
        self.stats.counters.bonds_broken += 1;
        true
    }
}

/// The share of a step at which the first bond reaches its strength, its margin
/// ([`Contact::bond_margin`](crate::contact::Contact::bond_margin)) interpolated linearly between the step's start (`committed`)
/// and its end (`reached`, where some bond is past its strength): below its strength at the
/// start, a bond's forces follow the load almost linearly while it holds.
pub(super) fn first_crossing(committed: &ContactSet, reached: &ContactSet) -> f64 {
    let mut crossing = 1.0f64;
    for c in &reached.contacts {
        let Some(end) = c.bond_margin().filter(|&m| m > 0.0) else {
            continue;
        };
        let start = committed
            .contacts
            .binary_search_by(|d| d.pair.cmp(&c.pair))
            .ok()
            .and_then(|i| committed.contacts[i].bond_margin())
            .filter(|&m| m < 0.0);
        let at = start.map_or(0.0, |m| m / (m - end));
        crossing = crossing.min(at);
    }
    crossing
}

/// Where to cut a step whose end has a bond past its strength, `bracket` being the share of
/// the step that changes the load by [`BRACKET`](super::increment::BRACKET): a part that ends half a bracket short of
/// the predicted `crossing`, then one that goes 0.9 of a bracket on from there, within
/// which the bond breaks where the prediction holds (a crossing within a bracket of the
/// start: that part alone). Where it does not, each part is cut again from its own ends, a
/// secant search; the bond still breaks within a bracket of its load. Bisection takes
/// `log2(1 / bracket)` parts, each a minimisation, to the same end.
pub(super) fn bracketing_cuts(crossing: f64, bracket: f64) -> Vec<f64> {
    let cuts = if crossing > bracket {
        let below = crossing - 0.5 * bracket;
        vec![below, below + 0.9 * bracket]
    } else {
        vec![0.9 * bracket]
    };
    cuts.into_iter().filter(|&c| c < 1.0).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bracketing_cuts_straddle_the_predicted_break_within_one_bracket() {
        // A bracket of a tenth of the step, the bond predicted to break at 0.62: a part to
        // 0.57, then one to 0.66, which holds the break and changes the load by 0.9 brackets.
        let cuts = bracketing_cuts(0.62, 0.1);
        assert_eq!(cuts.len(), 2);
        assert!((cuts[0] - 0.57).abs() < 1e-12 && (cuts[1] - 0.66).abs() < 1e-12);
        // Within a bracket of the start: one part of 0.9 brackets holds it.
        let cuts = bracketing_cuts(0.05, 0.1);
        assert!(cuts.len() == 1 && (cuts[0] - 0.09).abs() < 1e-12);
        // Near the end: the cut past the end goes.
        assert_eq!(bracketing_cuts(0.99, 0.1).len(), 1);
    }
}
