//! The matrix `examples/factorisation.rs` times: `Simulation::next_tangent` gives the matrix
//! the next increment's minimisation factorises first, on the simulation's pattern:
//! symmetric, with a positive diagonal, and a Cholesky factorisation of it succeeds; the
//! simulation is left ready for that increment.

use faer::sparse::SparseColMatRef;
use grainstat::samples;
use grainstat::scene::build_grains;
use grainstat::simulation::Simulation;
use grainstat::solver::{LinearSolver, SolverConfig, SolverStats};
use std::collections::HashMap;
use std::path::Path;

#[test]
fn the_next_tangent_is_symmetric_and_factorises() {
    let scene = samples::crystal_biaxial(11, 7, 1e6, 3e6);
    let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
    let mut sim = Simulation::new(&scene, grains, SolverConfig::default(), "t").unwrap();
    let (pattern, values) = sim.next_tangent(0.0).unwrap();
    let symbolic = pattern.symbolic.as_ref();
    assert_eq!(values.len(), symbolic.row_idx().len());
    let mut entries = HashMap::new();
    for col in 0..symbolic.ncols() {
        for (k, row) in symbolic.row_idx_of_col(col).enumerate() {
            let slot = symbolic.col_ptr()[col] as usize + k;
            entries.insert((row, col), values[slot]);
        }
    }
    let scale = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.0);
    for (&(row, col), &value) in &entries {
        let mirror = entries.get(&(col, row)).copied().unwrap_or(0.0);
        assert!(
            (value - mirror).abs() <= 1e-12 * scale,
            "K[{row}, {col}] = {value:e} against K[{col}, {row}] = {mirror:e}"
        );
    }
    for (dof, &slot) in pattern.diagonal.iter().enumerate() {
        assert!(values[slot] > 0.0, "diagonal {dof} is {:e}", values[slot]);
    }
    let mut linear = LinearSolver::new();
    let mut stats = SolverStats::default();
    linear.analyse(&pattern.symbolic, &mut stats).unwrap();
    let matrix = SparseColMatRef::new(symbolic, &values);
    linear.factorize(matrix, &mut stats).unwrap();
    let report = sim.run_increment().unwrap();
    assert!(report.residual <= sim.config.tolerance, "{report:?}");
}

#[test]
fn a_simulation_whose_load_program_is_done_has_no_next_tangent() {
    let scene = samples::crystal_biaxial(11, 7, 1e6, 3e6);
    let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
    let mut sim = Simulation::new(&scene, grains, SolverConfig::default(), "t").unwrap();
    sim.state.stage = sim.stages.len();
    match sim.next_tangent(0.0) {
        Err(grainstat::Error::Input(e)) => assert_eq!(e.key.as_deref(), Some("stages")),
        other => panic!("expected an input error, got {:?}", other.map(|_| ())),
    }
}
