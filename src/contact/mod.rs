//! Contacts: the set of touching pairs with their history, and the laws that give their
//! forces. History (shear force, bond) is committed only when an increment converges
//! (backup / restore, as pmsim does), so a failed increment can be cut and retried.

mod kinematics;
pub use kinematics::kinematics;
mod law;

pub use kinematics::{Configuration, Kinematics};
pub use law::{
    friction, hertz_stiffness, kappa, mean_radius, ContactLaw, ContactParams, Friction,
    HertzMindlin, LinearCohesive, Response,
};

use crate::geometry::{Pair, Side};

/// The state of a contact as written to the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum ContactState {
    /// Elastic, below the Coulomb limit.
    Elastic = 0,
    /// On the Coulomb limit.
    Sliding = 1,
    /// Cemented, bond intact.
    Bonded = 2,
    /// Cemented once, bond broken, still touching.
    Broken = 3,
}

/// How a bond broke (eqs. 11 and 12).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum BreakMode {
    /// `F_n < -F_t`.
    Tension = 0,
    /// `|F_s| > f F_n + F_t`.
    Shear = 1,
}

/// A bond that broke: kept after the grains part, for crack pictures and counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrokenBond {
    /// The pair.
    pub pair: Pair,
    /// Increment in which it broke.
    pub increment: usize,
    /// Tension or shear.
    pub mode: BreakMode,
}

/// One contact: its pair, its properties and its history.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    /// The two sides.
    pub pair: Pair,
    /// Fixed law parameters.
    pub params: ContactParams,
    /// Whether the cement bond is intact.
    pub bonded: bool,
    /// Whether it was cemented and the bond broke.
    pub broken: bool,
    /// Committed shear force at the start of the increment (N).
    pub shear_force0: f64,
    /// Committed accumulated shear displacement `s_h` at the start of the increment (m).
    pub shear_displacement0: f64,
    /// Shear displacement of the increment already made before the contact was (re)made.
    pub shear_offset: f64,
    /// The current response (trial during a solve, converged after it).
    pub response: Response,
    /// The current overlap `n` (m).
    pub overlap: f64,
    /// The current shear displacement of this increment (m).
    pub shear_increment: f64,
    /// Overlap at the start of the increment (m): a pair apart then counts its shear from
    /// where its surfaces touched.
    pub start_overlap: f64,
    /// What the minimisation of the increment holds fixed between two refreezes.
    pub lag: Lag,
    /// The contact's potential at the current response, with the lag held (J).
    pub energy: f64,
}

/// The part of a contact's response that the minimisation of an increment lags (method
/// note, step 2): frozen at an accepted iterate, held along the line search that follows,
/// so the friction force is the derivative of a potential.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Lag {
    /// Shear stiffness `k_s` (N/m).
    pub shear_stiffness: f64,
    /// Coulomb limit `f N` (N); `INFINITY` while bonded or with infinite friction.
    pub limit: f64,
    /// Overlap at the last refreeze (m).
    pub overlap: f64,
    /// Whether a pair apart at the start of the increment has been found touching: its
    /// shear then counts from the touching point found then.
    pub touched: bool,
    /// Whether such a pair has already been found touching once in this increment: only
    /// that first touch sticks it until the next refreeze.
    pub made: bool,
    /// Whether the overlap fell by half or more since the refreeze before: a Hertz contact
    /// unloading towards zero then gets its secant stiffness `F/n`, which reaches zero in one
    /// step, where the tangent `1.5 F/n` only divides the overlap by three.
    pub unloading: bool,
    /// Overlap where the last consistent tangent was taken (m): the same secant rule for the
    /// semi-smooth steps, whose every evaluation refreezes the lag.
    pub newton_overlap: f64,
    /// How far the last refreeze found the limit from `f N` (N), and the share of that it
    /// took: the secant of the limit's own fixed point (see [`Lag::refrozen_limit`]).
    pub limit_change: f64,
    /// See `limit_change`.
    pub limit_share: f64,
}

impl Lag {
    /// The limit refrozen towards `target`, the Coulomb limit `f N` where the contact is now.
    /// The lag is a fixed-point iteration, and on a contact whose normal force its own
    /// friction drives (a grain wedged, a cluster swinging on a contact that slides) it
    /// oscillates: the limit overshoots one way, then the other. Where the change turns back,
    /// the limit moves by the share the secant through the last two changes gives (Aitken's
    /// relaxation of a fixed-point iteration), which stops an oscillation of gain -1 in one
    /// refreeze; elsewhere it takes the target.
    pub fn refrozen_limit(&mut self, target: f64) -> f64 {
        if !self.limit.is_finite() {
            return target;
        }
        let change = target - self.limit;
        let share = if change * self.limit_change < 0.0 {
            (self.limit_share * self.limit_change / (self.limit_change - change))
                .clamp(LIMIT_SHARE_MIN, 1.0)
        } else {
            1.0
        };
        (self.limit_change, self.limit_share) = (change, share);
        (self.limit + share * change).max(0.0)
    }
}

/// Smallest share of its change a refrozen limit takes where the change turns back.
const LIMIT_SHARE_MIN: f64 = 0.05;

impl Contact {
    /// A fresh contact with no history.
    pub fn new(pair: Pair, params: ContactParams, bonded: bool) -> Self {
        Contact {
            pair,
            params,
            bonded,
            broken: false,
            shear_force0: 0.0,
            shear_displacement0: 0.0,
            shear_offset: 0.0,
            response: Response::default(),
            overlap: 0.0,
            shear_increment: 0.0,
            start_overlap: 0.0,
            lag: Lag::default(),
            energy: 0.0,
        }
    }

    /// The output state.
    pub fn state(&self) -> ContactState {
        if self.bonded {
            ContactState::Bonded
        } else if self.broken {
            ContactState::Broken
        } else if self.response.sliding {
            ContactState::Sliding
        } else {
            ContactState::Elastic
        }
    }

    /// Whether an intact bond fails at the current response, and how: in tension when
    /// `F_n < -F_t` (eq. 12), in shear when `|F_s| > f F_n + F_t` (eq. 11). Exactly on the
    /// limit it holds. A bond with a wall is glue ([`ContactSet::glued`]): the grain moves
    /// with the wall, so the bond carries nothing that changes, and it holds.
    pub fn bond_failure(&self) -> Option<BreakMode> {
        self.bond_overload().map(|(_, mode)| mode)
    }

    /// How far an intact bond between two grains is past its strength, in newtons: the larger
    /// of `-F_n - F_t` (tension) and `|F_s| - (f F_n + F_t)` (shear), positive where it is
    /// overloaded ([`Contact::bond_overload`]). `None` for anything else.
    pub fn bond_margin(&self) -> Option<f64> {
        let (fn_, fs, ft, shear_limit) = self.bond_limits()?;
        Some((-fn_ - ft).max(fs.abs() - shear_limit))
    }

    /// How far past its strength an intact bond is, as the ratio of its force to what it can
    /// carry (above 1), and how it fails: `-F_n / F_t` in tension (eq. 12), `|F_s| / (f F_n +
    /// F_t)` in shear (eq. 11); the larger counts. `None` while it holds (see
    /// [`Contact::bond_failure`]).
    pub fn bond_overload(&self) -> Option<(f64, BreakMode)> {
        let (fn_, fs, ft, shear_limit) = self.bond_limits()?;
        let tension = (fn_ < -ft).then(|| (-fn_ / ft, BreakMode::Tension));
        let shear = (fs.abs() > shear_limit).then(|| (fs.abs() / shear_limit, BreakMode::Shear));
        match (tension, shear) {
            (Some(t), Some(s)) => Some(if s.0 > t.0 { s } else { t }),
            (t, s) => t.or(s),
        }
    }

    /// An intact bond between two grains: its normal and shear forces, its strength `F_t`
    /// and its shear limit `f F_n + F_t` (infinite with infinite friction).
    fn bond_limits(&self) -> Option<(f64, f64, f64, f64)> {
        if !self.bonded || matches!(self.pair.a, Side::Wall(_)) {
            return None;
        }
        let (fn_, fs) = (self.response.normal_force, self.response.shear_force);
        let ft = self.params.strength;
        let shear_limit = if self.params.friction.is_infinite() {
            f64::INFINITY
        } else {
            self.params.friction * fn_ + ft
        };
        Some((fn_, fs, ft, shear_limit))
    }

    /// Accumulated shear displacement including this increment.
    pub fn shear_displacement(&self) -> f64 {
        self.shear_displacement0 + self.shear_increment
    }

    /// Make the converged response the new history.
    pub fn commit(&mut self) {
        self.start_overlap = self.overlap;
        self.shear_force0 = self.response.shear_force;
        self.shear_displacement0 += self.shear_increment;
        self.shear_offset = 0.0;
        self.shear_increment = 0.0;
    }
}

/// A contact as the committed state holds it, and as the result file keeps it: what an
/// increment starts from. The rest of a [`Contact`] is the increment's own (the shear made in
/// it, the lag, the energy), made anew as the increment is solved, so the contact this gives
/// back is the committed one, as a run resumed from the file has it. Under half a contact's
/// size, it is what an increment keeps to go back to (some 290 MB less at a million grains).
#[derive(Debug, Clone, PartialEq)]
pub struct CommittedContact {
    /// The two sides.
    pub pair: Pair,
    /// Fixed law parameters.
    pub params: ContactParams,
    /// Whether the cement bond is intact.
    pub bonded: bool,
    /// Whether it was cemented and the bond broke.
    pub broken: bool,
    /// Accumulated shear displacement `s_h` (m).
    pub shear_displacement: f64,
    /// Overlap `n` (m).
    pub overlap: f64,
    /// The response: its shear force is the history the next increment starts from.
    pub response: Response,
}

impl CommittedContact {
    /// The contact an increment starts from.
    pub fn contact(&self) -> Contact {
        Contact {
            pair: self.pair,
            params: self.params,
            bonded: self.bonded,
            broken: self.broken,
            shear_force0: self.response.shear_force,
            shear_displacement0: self.shear_displacement,
            shear_offset: 0.0,
            response: self.response,
            overlap: self.overlap,
            shear_increment: 0.0,
            start_overlap: self.overlap,
            lag: Lag::default(),
            energy: 0.0,
        }
    }
}

impl Contact {
    /// Its committed state; it must be committed (see [`Contact::is_committed`]).
    pub fn committed(&self) -> CommittedContact {
        debug_assert!(
            self.is_committed(),
            "an uncommitted contact {:?}",
            self.pair
        );
        CommittedContact {
            pair: self.pair,
            params: self.params,
            bonded: self.bonded,
            broken: self.broken,
            shear_displacement: self.shear_displacement0,
            overlap: self.overlap,
            response: self.response,
        }
    }

    /// Whether it is as [`Contact::commit`] leaves it, its history its response.
    pub fn is_committed(&self) -> bool {
        self.shear_offset == 0.0
            && self.shear_increment == 0.0
            && self.start_overlap.to_bits() == self.overlap.to_bits()
            && self.shear_force0.to_bits() == self.response.shear_force.to_bits()
    }
}

/// A committed [`ContactSet`], kept by an increment to go back to.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CommittedSet {
    /// The contacts, ordered by pair.
    pub contacts: Vec<CommittedContact>,
    /// Bonds broken so far.
    pub broken_bonds: Vec<BrokenBond>,
}

impl CommittedSet {
    /// Whether `set` is this committed set.
    pub fn holds(&self, set: &ContactSet) -> bool {
        self.broken_bonds == set.broken_bonds
            && self.contacts.len() == set.contacts.len()
            && (self.contacts.iter().zip(&set.contacts))
                .all(|(k, c)| c.is_committed() && *k == c.committed())
    }

    /// The contact set it is.
    pub fn restore(&self) -> ContactSet {
        ContactSet {
            contacts: self
                .contacts
                .iter()
                .map(CommittedContact::contact)
                .collect(),
            broken_bonds: self.broken_bonds.clone(),
        }
    }
}

/// All current contacts, ordered by pair, so every pass visits them in the same order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ContactSet {
    /// The contacts.
    pub contacts: Vec<Contact>,
    /// Bonds broken so far.
    pub broken_bonds: Vec<BrokenBond>,
}

impl ContactSet {
    /// Number of contacts.
    pub fn len(&self) -> usize {
        self.contacts.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.contacts.is_empty()
    }

    /// Commit every contact's converged response as its history.
    pub fn commit(&mut self) {
        self.contacts.iter_mut().for_each(Contact::commit);
    }

    /// The committed state, to go back to (every contact committed).
    pub fn committed(&self) -> CommittedSet {
        CommittedSet {
            contacts: self.contacts.iter().map(Contact::committed).collect(),
            broken_bonds: self.broken_bonds.clone(),
        }
    }

    /// The wall each of `grains` grains is glued to, if any. A grain is glued by bonding its
    /// contact with the wall (a wall contact is bonded for nothing else), so the glue is
    /// part of the contact history the result file keeps; the lowest wall holds a grain
    /// bonded to two.
    pub fn glued(&self, grains: usize) -> Vec<Option<usize>> {
        let mut glued = vec![None; grains];
        for c in self.contacts.iter().filter(|c| c.bonded) {
            if let (Side::Wall(w), None) = (c.pair.a, glued[c.pair.b]) {
                glued[c.pair.b] = Some(w);
            }
        }
        glued
    }

    /// Mean magnitude of the normal force (N) (the force scale of the convergence test).
    pub fn mean_normal_force(&self) -> f64 {
        if self.contacts.is_empty() {
            return 0.0;
        }
        self.contacts
            .iter()
            .map(|c| c.response.normal_force.abs())
            .sum::<f64>()
            / self.contacts.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Side;

    fn bonded(normal_force: f64, shear_force: f64) -> Contact {
        let params = ContactParams {
            stiffness: 1e6,
            kappa: kappa(0.16),
            friction: 0.5,
            strength: 2.0,
        };
        let mut c = Contact::new(
            Pair {
                a: Side::Grain(0),
                b: 1,
            },
            params,
            true,
        );
        c.response.normal_force = normal_force;
        c.response.shear_force = shear_force;
        c
    }

    #[test]
    fn bond_margin_is_positive_exactly_where_the_bond_is_overloaded() {
        // Tension: F_t = 2 less the pull; shear: |F_s| less f F_n + F_t = 4.
        assert_eq!(bonded(-3.0, 0.0).bond_margin(), Some(1.0));
        assert_eq!(bonded(4.0, -5.0).bond_margin(), Some(1.0));
        assert_eq!(bonded(4.0, 1.0).bond_margin(), Some(-3.0));
        for (fn_, fs) in [
            (-2.5, 0.0),
            (-2.0, 0.0),
            (4.0, 4.0),
            (4.0, -4.5),
            (1.0, 0.1),
        ] {
            let c = bonded(fn_, fs);
            assert_eq!(c.bond_margin().unwrap() > 0.0, c.bond_overload().is_some());
        }
        let mut apart = bonded(-3.0, 0.0);
        apart.bonded = false;
        assert_eq!(apart.bond_margin(), None);
    }

    #[test]
    fn bonded_pair_breaks_exactly_at_the_tension_cut_off() {
        // Eq. 12: F_n < -F_t breaks; F_n = -F_t holds.
        assert_eq!(bonded(-2.0, 0.0).bond_failure(), None);
        let beyond = -2.0 * (1.0 + f64::EPSILON);
        assert_eq!(bonded(beyond, 0.0).bond_failure(), Some(BreakMode::Tension));
    }

    /// A committed contact kept and given back is the contact, its lag and energy apart (the
    /// increment's own, made anew before they are read); one in the middle of an increment
    /// is not committed.
    #[test]
    fn a_committed_contact_is_kept_whole() {
        let mut c = bonded(3.0, -0.5);
        (c.overlap, c.start_overlap, c.shear_force0) = (2e-6, -1e-6, 0.25);
        (c.shear_displacement0, c.shear_increment, c.shear_offset) = (4e-7, 3e-7, 1e-7);
        (c.response.sliding, c.response.dfn_dn, c.response.dfs_ds) = (true, 7.0, 8.0);
        c.lag.limit = 1.5;
        c.energy = 9.0;
        assert!(!c.is_committed());
        c.commit();
        assert!(c.is_committed());
        let back = c.committed().contact();
        assert_eq!(back.lag, Lag::default());
        assert_eq!(back.energy, 0.0);
        assert_eq!(
            Contact {
                lag: Lag::default(),
                energy: 0.0,
                ..c.clone()
            },
            back
        );
        let set = ContactSet {
            contacts: vec![c.clone()],
            broken_bonds: Vec::new(),
        };
        let kept = set.committed();
        assert!(kept.holds(&set) && kept.holds(&kept.restore()));
        let mut moved = set.clone();
        moved.contacts[0].overlap = 3e-6;
        assert!(!kept.holds(&moved));
    }

    #[test]
    fn bonded_pair_cracks_exactly_at_the_shear_limit() {
        // Eq. 11: |F_s| > f F_n + F_t cracks; on the limit it holds.
        let limit = 0.5 * 4.0 + 2.0;
        assert_eq!(bonded(4.0, limit).bond_failure(), None);
        assert_eq!(bonded(4.0, -limit).bond_failure(), None);
        let beyond = limit * (1.0 + f64::EPSILON);
        assert_eq!(bonded(4.0, -beyond).bond_failure(), Some(BreakMode::Shear));
    }
}
