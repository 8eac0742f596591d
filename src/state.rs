//! The state of a run: exactly what is written to HDF5 after each increment and read back to
//! resume. Everything else (factorisations, buffers, the pattern) is workspace, rebuilt from it.

use crate::contact::{CommittedSet, ContactSet};
use crate::geometry::{GrainSet, Membrane, Side, WallSet};
use crate::measure::Measurements;
use crate::simulation::EnergyBalance;
use std::ops::{Deref, DerefMut};
use std::sync::Arc;

/// Where a run stands: committed positions, wall states, contact history, and the place in
/// the load program.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Load increments completed so far.
    pub increment: usize,
    /// Index of the current stage of the load program.
    pub stage: usize,
    /// Increments completed within the current stage.
    pub stage_increment: usize,
    /// Grains at the last converged increment.
    pub grains: Shared<GrainSet>,
    /// Walls at the last converged increment (positions, slides, applied stresses).
    pub walls: WallSet,
    /// Contacts and their committed history; bonds broken so far.
    pub contacts: Shared<ContactSet>,
    /// Membranes and their pressures (their chains are found anew each increment).
    pub membranes: Vec<Membrane>,
    /// Grain centres when the friends lists were last made: rebuilding the lists from them
    /// gives the same pattern, so a resumed run repeats the uninterrupted one exactly.
    pub friends_reference: Vec<[f64; 2]>,
    /// Wall positions (normal, along) when the friends lists were last made.
    pub friends_wall_reference: Vec<[f64; 2]>,
    /// Each unknown's displacement in the last increment of the current stage (empty at a
    /// stage's start): the predictor the next increment starts from.
    pub last_step: Vec<f64>,
    /// The clusters of grains taken out of the sample so far, in order (see
    /// [`crate::simulation::Simulation::take_out`]); their grains are those marked in
    /// [`GrainSet::taken_out`].
    pub breakouts: Vec<Breakout>,
}

/// A committed state kept to go back to (the state an increment starts from): its contacts as
/// the result file keeps them ([`CommittedSet`], under half their size in the state), the
/// rest shared with the state until either changes. The state goes on changing its contacts
/// in place, where a second holder of them would make it copy them whole.
#[derive(Debug, Clone)]
pub struct KeptState {
    /// The state with no contacts.
    rest: State,
    /// Its contacts.
    contacts: CommittedSet,
}

impl KeptState {
    /// Keep `state`, committed.
    pub fn of(state: &State) -> Self {
        KeptState {
            rest: State {
                contacts: ContactSet::default().into(),
                ..state.clone()
            },
            contacts: state.contacts.committed(),
        }
    }

    /// The state kept.
    pub fn state(&self) -> State {
        State {
            contacts: self.contacts.restore().into(),
            ..self.rest.clone()
        }
    }

    /// Its contacts.
    pub fn contacts(&self) -> &CommittedSet {
        &self.contacts
    }
}

/// A part of the state held once by all its copies until one of them changes it (copy on
/// write). A run holds the state, the one its increment started from (to go back to), and
/// the one its result file is being written from: most often all the same, and the grains'
/// and contacts' vectors are most of a state's memory.
#[derive(Debug, Default)]
pub struct Shared<T>(Arc<T>);

impl<T> Clone for Shared<T> {
    /// Another holder of the same value: nothing is copied.
    fn clone(&self) -> Self {
        Shared(Arc::clone(&self.0))
    }
}

impl<T> Deref for Shared<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

impl<T: Clone> DerefMut for Shared<T> {
    /// The value to change, copied first if another holder has it too.
    fn deref_mut(&mut self) -> &mut T {
        Arc::make_mut(&mut self.0)
    }
}

impl<T: Clone> Shared<T> {
    /// The value, copied only if another holder has it too.
    pub fn into_inner(self) -> T {
        Arc::unwrap_or_clone(self.0)
    }
}

impl<T: PartialEq> PartialEq for Shared<T> {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || *self.0 == *other.0
    }
}

impl<T> From<T> for Shared<T> {
    fn from(value: T) -> Self {
        Shared(Arc::new(value))
    }
}

/// A cluster of grains that broke out of the sample and was taken out of it: the thesis's
/// functional failure of the cylinder test (4.4.2) starts with the first.
#[derive(Debug, Clone, PartialEq)]
pub struct Breakout {
    /// The load increment (1-based) in which it was taken out.
    pub increment: usize,
    /// The grains taken out, in increasing order.
    pub grains: Vec<usize>,
    /// Bonds between the cluster and the rest of the sample, broken as it was taken out.
    pub bonds_broken: usize,
    /// Each membrane's pressure when it was taken out (Pa): the last the sample carried in
    /// equilibrium with the cluster in it.
    pub pressure: Vec<f64>,
    /// Each wall's applied stress then (Pa), `None` for a wall under displacement control.
    pub stress: Vec<Option<f64>>,
    /// Whether it is debris, not the wall breaking: no grain of it was ever cemented, and
    /// none touched anything at the last equilibrium (a rattler of the sample squeezed out).
    /// It is taken out as any breakout, but is no functional failure: a stage that ends at its
    /// first breakout goes on past it, and the cylinder test's first breakout is the first
    /// that is not debris.
    pub debris: bool,
}

impl Breakout {
    /// The loads carried, by name: each membrane's pressure and each stress-controlled wall's
    /// stress (Pa), as [`crate::run::Failure::carried`] has them.
    pub fn carried(&self, membranes: &[Membrane], walls: &WallSet) -> Vec<(String, f64)> {
        let pressures = membranes.iter().zip(&self.pressure);
        let stresses = walls.walls.iter().zip(&self.stress);
        (pressures.map(|(m, &p)| (m.name.clone(), p)))
            .chain(stresses.filter_map(|(w, s)| s.map(|s| (w.name.clone(), s))))
            .collect()
    }
}

/// What one converged increment reports: the state's measurements and how the solver did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IncrementReport {
    /// The increment (1-based).
    pub increment: usize,
    /// The stage it belongs to.
    pub stage: usize,
    /// Macro measurements of the converged state.
    pub measurements: Measurements,
    /// Final relative residual `|R|_inf / F_ref`.
    pub residual: f64,
    /// Newton iterations of the minimisation (sweeps of the relaxation) over all passes and
    /// sub-steps.
    pub newton_iterations: usize,
    /// Passes: the minimisation's end where a step reaches the edge of the friends lists, the
    /// relaxation's where the topology is updated.
    pub topology_passes: usize,
    /// Times the increment was halved.
    pub cuts: u32,
    /// Contacts made in this increment.
    pub contacts_made: usize,
    /// Contacts lost in this increment.
    pub contacts_lost: usize,
    /// Bonds broken in this increment.
    pub bonds_broken: usize,
    /// The stability indicator: negative pivots of an `L D L^T` of the symmetric tangent at
    /// the converged state, i.e. its negative eigenvalues (`None` when not counted). Zero in
    /// a stable equilibrium; positive where a mode of the sample softens (the onset of
    /// failure).
    pub negative_pivots: Option<usize>,
    /// The increment's energy balance.
    pub energy: EnergyBalance,
    /// The part of the increment found in equilibrium at which the macro stress's deviator
    /// was highest, where that is not its end: halves of an increment commit as they
    /// converge, and one that ends just before a bond breaks holds the test's peak, which
    /// the increment's end, past the break, has left.
    pub peak: Option<PeakState>,
}

impl IncrementReport {
    /// The increment's peak, else its end on `walls` (the walls as it left them).
    pub fn peak_or_end(&self, walls: &WallSet) -> PeakState {
        (self.peak.clone()).unwrap_or_else(|| PeakState::of(walls, &self.measurements))
    }

    /// Take `candidate` as the increment's peak where its deviator is higher than the peak's,
    /// else than the end's.
    pub fn keep_peak(&mut self, candidate: PeakState) {
        let highest = self.peak.as_ref().map_or_else(
            || deviator(&self.measurements.macro_stress),
            PeakState::deviator,
        );
        if candidate.deviator() > highest {
            self.peak = Some(candidate);
        }
    }
}

/// A state within an increment, found in equilibrium on the way to its end, kept for a
/// test's peak.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PeakState {
    /// Each wall's position (m).
    pub wall_position: Vec<f64>,
    /// Each wall's stress as the grains put it on the wall (Pa).
    pub wall_stress: Vec<f64>,
    /// The macro stress (Pa), indexed as [`Measurements::macro_stress`].
    pub macro_stress: [[f64; 2]; 2],
}

impl PeakState {
    /// The walls as they are, with the measurements `m` taken there.
    pub fn of(walls: &WallSet, m: &Measurements) -> PeakState {
        PeakState {
            wall_position: walls.walls.iter().map(|w| w.position).collect(),
            wall_stress: m.wall_stress.clone(),
            macro_stress: m.macro_stress,
        }
    }

    /// The difference of the macro stress's principal stresses (Pa).
    pub fn deviator(&self) -> f64 {
        deviator(&self.macro_stress)
    }
}

/// The difference of the principal stresses of `stress`'s symmetric part (Pa).
pub fn deviator(stress: &[[f64; 2]; 2]) -> f64 {
    (stress[0][0] - stress[1][1]).hypot(stress[0][1] + stress[1][0])
}

impl State {
    /// The state of a fresh sample: nothing done yet, the friends lists to be made where
    /// everything is now.
    pub fn fresh(
        grains: GrainSet,
        walls: WallSet,
        contacts: ContactSet,
        membranes: Vec<Membrane>,
    ) -> State {
        State {
            increment: 0,
            stage: 0,
            stage_increment: 0,
            friends_reference: grains.position.clone(),
            friends_wall_reference: walls.walls.iter().map(|w| [w.position, w.slide]).collect(),
            last_step: Vec::new(),
            breakouts: Vec::new(),
            grains: grains.into(),
            walls,
            contacts: contacts.into(),
            membranes,
        }
    }

    /// Grains taken out of the sample so far.
    pub fn grains_taken_out(&self) -> usize {
        self.breakouts.iter().map(|b| b.grains.len()).sum()
    }

    /// Keep only the walls named in `keep`, dropping the others with their contacts: how a
    /// test changes the boundary a sample was prepared in (a borehole freed of its plug, the
    /// sides of a biaxial test handed to membranes).
    pub fn keep_walls(&mut self, keep: &[&str]) {
        let old = std::mem::take(&mut self.walls.walls);
        let mut index = vec![None; old.len()];
        let mut reference = Vec::new();
        for (w, wall) in old.into_iter().enumerate() {
            if keep.contains(&wall.name.as_str()) {
                index[w] = Some(self.walls.walls.len());
                reference.push(self.friends_wall_reference[w]);
                self.walls.walls.push(wall);
            }
        }
        self.friends_wall_reference = reference;
        for breakout in &mut self.breakouts {
            let stress = std::mem::take(&mut breakout.stress);
            breakout.stress = (stress.into_iter().enumerate())
                .filter_map(|(w, s)| index[w].map(|_| s))
                .collect();
        }
        self.contacts.contacts.retain_mut(|c| match c.pair.a {
            Side::Wall(w) => match index[w] {
                Some(k) => {
                    c.pair.a = Side::Wall(k);
                    true
                }
                None => false,
            },
            Side::Grain(_) => true,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::{Contact, ContactParams};
    use crate::geometry::{Pair, Wall, WallControl};

    #[test]
    fn keep_walls_drops_walls_and_their_contacts_and_renumbers_the_rest() {
        let wall = |name: &str| Wall {
            name: name.into(),
            normal: [0.0, 1.0],
            offset: 0.0,
            pivot: [0.0; 2],
            turn: 0.0,
            position: 0.0,
            slide: 0.0,
            control: WallControl::Displacement,
            stress: 0.0,
            length: None,
            friction: 0.0,
            circle: None,
        };
        let params = ContactParams {
            stiffness: 1.0,
            kappa: 1.0,
            friction: 0.5,
            strength: 0.0,
        };
        let contact = |a: Side, b: usize| Contact::new(Pair { a, b }, params, false);
        let mut state = State {
            increment: 0,
            stage: 0,
            stage_increment: 0,
            grains: GrainSet::new(vec![[0.0; 2]; 3], vec![1.0; 3]).into(),
            walls: WallSet {
                walls: vec![wall("bottom"), wall("right"), wall("top")],
            },
            contacts: ContactSet {
                contacts: vec![
                    contact(Side::Grain(0), 1),
                    contact(Side::Wall(0), 0),
                    contact(Side::Wall(1), 1),
                    contact(Side::Wall(2), 2),
                ],
                broken_bonds: Vec::new(),
            }
            .into(),
            friends_reference: vec![[0.0; 2]; 3],
            friends_wall_reference: vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]],
            last_step: Vec::new(),
            breakouts: Vec::new(),
            membranes: Vec::new(),
        };
        state.keep_walls(&["bottom", "top"]);
        let names: Vec<&str> = state.walls.walls.iter().map(|w| w.name.as_str()).collect();
        assert_eq!(names, ["bottom", "top"]);
        assert_eq!(state.friends_wall_reference, vec![[0.0, 0.0], [2.0, 0.0]]);
        let pairs: Vec<Side> = state.contacts.contacts.iter().map(|c| c.pair.a).collect();
        assert_eq!(pairs, [Side::Grain(0), Side::Wall(0), Side::Wall(1)]);
        assert_eq!(state.contacts.contacts[2].pair.b, 2);
    }
}
