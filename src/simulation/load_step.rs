//! What the load program does to the walls in one load increment, and its halves.

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
    /// The step split in two halves, stresses and pressures passing through the midpoint from
    /// where they are (`from_stress`, `from_pressure`).
    pub fn halves(&self, from_stress: &[f64], from_pressure: &[f64]) -> (LoadStep, LoadStep) {
        let mid = |to: &[f64], from: &[f64]| -> Vec<f64> {
            to.iter().zip(from).map(|(t, f)| 0.5 * (t + f)).collect()
        };
        let half = LoadStep {
            normal_move: self.normal_move.iter().map(|m| 0.5 * m).collect(),
            slide: self.slide.iter().map(|m| 0.5 * m).collect(),
            turn: self.turn.iter().map(|m| 0.5 * m).collect(),
            stress: mid(&self.stress, from_stress),
            pressure: mid(&self.pressure, from_pressure),
        };
        let rest = LoadStep {
            stress: self.stress.clone(),
            pressure: self.pressure.clone(),
            ..half.clone()
        };
        (half, rest)
    }
}
