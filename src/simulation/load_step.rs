//! What the load program does to the walls in one load increment, and its parts; a wall's
//! stress set between increments.

use super::Simulation;
use crate::geometry::WallControl;
use crate::InputError;

/// What the load program does to the walls in one (sub-)increment.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadStep {
    /// Normal move of each wall in this step (m) (prescribed walls only).
    pub normal_move: Vec<f64>,
    /// Move along each wall in this step (m).
    pub slide: Vec<f64>,
    /// Turn of each straight wall about its pivot in this step (rad, anticlockwise).
    pub turn: Vec<f64>,
    /// Stress on each wall at the end of this step (Pa) (stress-controlled walls).
    pub stress: Vec<f64>,
    /// Pressure on each membrane at the end of this step (Pa).
    pub pressure: Vec<f64>,
}

impl LoadStep {
    /// The step split in two where `share` (between 0 and 1) of it is made, stresses and
    /// pressures passing through that share of their change from where they are
    /// (`from_stress`, `from_pressure`).
    pub fn split(
        &self,
        share: f64,
        from_stress: &[f64],
        from_pressure: &[f64],
    ) -> (LoadStep, LoadStep) {
        let scaled =
            |moves: &[f64], by: f64| -> Vec<f64> { moves.iter().map(|m| by * m).collect() };
        let between = |to: &[f64], from: &[f64]| -> Vec<f64> {
            to.iter()
                .zip(from)
                .map(|(t, f)| f + share * (t - f))
                .collect()
        };
        let first = LoadStep {
            normal_move: scaled(&self.normal_move, share),
            slide: scaled(&self.slide, share),
            turn: scaled(&self.turn, share),
            stress: between(&self.stress, from_stress),
            pressure: between(&self.pressure, from_pressure),
        };
        let rest = LoadStep {
            normal_move: scaled(&self.normal_move, 1.0 - share),
            slide: scaled(&self.slide, 1.0 - share),
            turn: scaled(&self.turn, 1.0 - share),
            stress: self.stress.clone(),
            pressure: self.pressure.clone(),
        };
        (first, rest)
    }
}

impl Simulation {
    /// Load wall `wall` to `stress` (Pa) in the next increment, in place of its stage's step,
    /// and hold it there for the rest of the stage: a load path computed between increments.
    /// The wall must be under stress control in the next increment, from before it (a wall
    /// that turns to stress control as its stage starts takes the grains' stress then).
    pub fn set_wall_stress(&mut self, wall: &str, stress: f64) -> Result<(), InputError> {
        let bad = |message: String| InputError::new("set_wall_stress", message);
        if self.is_finished() {
            return Err(bad(
                "the load program is done: no increment is left to load".into(),
            ));
        }
        if !stress.is_finite() {
            return Err(bad(format!(
                "the stress must be a finite number, not {stress}"
            )));
        }
        let walls = &self.state.walls.walls;
        let Some(w) = walls.iter().position(|x| x.name == wall) else {
            let names: Vec<&str> = walls.iter().map(|x| x.name.as_str()).collect();
            return Err(bad(format!(
                "no wall is named `{wall}`; the walls are: {}",
                names.join(", ")
            )));
        };
        let stage = &mut self.stages[self.state.stage];
        let control = stage.control.get(w).copied().unwrap_or(walls[w].control);
        if walls[w].control != WallControl::Stress || control != WallControl::Stress {
            return Err(bad(format!(
                "wall `{wall}` is not under stress control in stage '{}' (from its start)",
                stage.name
            )));
        }
        stage.stress[w] = None;
        self.stress_next.resize(walls.len(), None);
        self.stress_next[w] = Some(stress);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step() -> LoadStep {
        LoadStep {
            normal_move: vec![-4e-6, 0.0],
            slide: vec![0.0, 2e-6],
            turn: vec![1e-3, 0.0],
            stress: vec![3e6, 1e6],
            pressure: vec![5e6],
        }
    }

    #[test]
    fn a_split_moves_its_share_and_the_rest_ends_where_the_step_does() {
        let (first, rest) = step().split(0.25, &[1e6, 1e6], &[4e6]);
        assert_eq!(first.normal_move, vec![-1e-6, 0.0]);
        assert_eq!(rest.normal_move, vec![-3e-6, 0.0]);
        assert_eq!((first.slide[1], rest.slide[1]), (0.5e-6, 1.5e-6));
        assert_eq!((first.turn[0], rest.turn[0]), (0.25e-3, 0.75e-3));
        assert_eq!(first.stress, vec![1.5e6, 1e6]);
        assert_eq!(first.pressure, vec![4.25e6]);
        assert_eq!(
            (rest.stress.clone(), rest.pressure.clone()),
            (step().stress, step().pressure)
        );
    }

    #[test]
    fn a_split_at_one_half_passes_through_the_midpoint_in_equal_moves() {
        let (first, rest) = step().split(0.5, &[2e6, 1e6], &[4e6]);
        assert_eq!(first.stress, vec![2.5e6, 1e6]);
        assert_eq!(first.pressure, vec![4.5e6]);
        assert_eq!(first.normal_move, rest.normal_move);
        assert_eq!(
            (first.slide.clone(), first.turn.clone()),
            (rest.slide, rest.turn)
        );
    }
}
