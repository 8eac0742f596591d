//! One factorisation of a run's own matrix: the sample of a result file at one of its written
//! increments (the last by default), the matrix the next increment's minimisation factorises
//! first (`Simulation::next_tangent`, the projected Hessian of its potential), then its
//! Cholesky, regularised as the minimisation would until it factorises (`lambda`). In each
//! fill-reducing ordering (AMD, METIS) it is analysed, then factorised and solved `--repeats`
//! times. Prints a markdown table of the factor's entries and the fastest and the
//! median time, to set a run's time per increment against.
//!
//!     cargo run --release --example factorisation -- results/cylinder-test-10000.h5
//!     cargo run --release --example factorisation -- RESULT.h5 --increment 14 --repeats 20

use faer::sparse::SparseColMatRef;
use grainstat::output::{read_increments, read_state};
use grainstat::scene::{parse_scene, parse_solver};
use grainstat::simulation::Simulation;
use grainstat::solver::linear::NotFactorizable;
use grainstat::solver::{FillOrdering, LinearSolver, SolverStats};
use std::time::Instant;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let increment = option(&mut args, "--increment");
    let repeats = option(&mut args, "--repeats").unwrap_or(10).max(1);
    let [path] = args.as_slice() else { usage() };
    if let Err(e) = report(path, increment, repeats) {
        eprintln!("{path}: {e}");
        std::process::exit(2);
    }
}

fn report(path: &str, increment: Option<usize>, repeats: usize) -> grainstat::Result<()> {
    let written = read_increments(path)?;
    let increment = match increment {
        Some(i) => i,
        None => *written.last().unwrap_or(&0),
    };
    let (header, state) = read_state(path, increment)?;
    let scene = parse_scene(&header.scene_text, path)?;
    // Files written before the Newton of topology passes was removed name its settings: the
    // defaults then.
    let config = parse_solver(&header.solver_text, path).unwrap_or_default();
    let grains = state.grains.len();
    println!(
        "{path}, increment {increment}: {grains} grains, {} contacts; {repeats} repeats",
        state.contacts.contacts.len()
    );
    println!();
    println!(
        "| ordering | unknowns | matrix entries | factor entries | lambda | analysis (s) | \
         factorisation, fastest (s) | factorisation, median (s) | solve, median (s) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut sim = Simulation::resume(&scene, state.clone(), header.depth, config.clone())?;
    let mut stats = SolverStats::default();
    let mut linear = LinearSolver::new();
    let mut lambda = 0.0f64;
    linear
        .analyse(&sim.next_tangent(lambda)?.0.symbolic, &mut stats)
        .map_err(singular)?;
    // Regularised further until it factorises, as the minimisation does.
    let (pattern, values) = loop {
        let (pattern, values) = sim.next_tangent(lambda)?;
        let matrix = SparseColMatRef::new(pattern.symbolic.as_ref(), &values);
        match linear.factorize(matrix, &mut stats) {
            Ok(()) => break (pattern, values),
            Err(e) if lambda > 1e6 => return Err(singular(e)),
            Err(_) => lambda = (lambda * 100.0).max(1e-8),
        }
    };
    let matrix = SparseColMatRef::new(pattern.symbolic.as_ref(), &values);
    for (name, ordering) in [("AMD", FillOrdering::Amd), ("METIS", FillOrdering::Metis)] {
        let mut linear = LinearSolver::in_order(ordering);
        let start = Instant::now();
        linear
            .analyse(&pattern.symbolic, &mut stats)
            .map_err(singular)?;
        let analysis = start.elapsed().as_secs_f64();
        let (mut factorise, mut solve) = (Vec::new(), Vec::new());
        let mut rhs = vec![0.0; pattern.diagonal.len()];
        for _ in 0..repeats {
            let start = Instant::now();
            linear.factorize(matrix, &mut stats).map_err(singular)?;
            factorise.push(start.elapsed().as_secs_f64());
            rhs.iter_mut().for_each(|r| *r = 1.0);
            let start = Instant::now();
            linear.solve_in_place(&mut rhs, &mut stats);
            solve.push(start.elapsed().as_secs_f64());
        }
        println!(
            "| {name} | {} | {} | {} | {} | {analysis:.3} | {:.4} | {:.4} | {:.5} |",
            pattern.diagonal.len(),
            pattern.nnz(),
            linear.factor_entries(),
            if lambda > 0.0 {
                format!("{lambda:.0e}")
            } else {
                "0".into()
            },
            fastest(&factorise),
            median(&mut factorise),
            median(&mut solve)
        );
    }
    Ok(())
}

fn singular(e: NotFactorizable) -> grainstat::Error {
    grainstat::NumericError::Singular { detail: e.0 }.into()
}

fn fastest(times: &[f64]) -> f64 {
    times.iter().copied().fold(f64::INFINITY, f64::min)
}

fn median(times: &mut [f64]) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// The whole number after `name`, taken out of `args`.
fn option(args: &mut Vec<String>, name: &str) -> Option<usize> {
    let at = args.iter().position(|a| a == name)?;
    let value = args.get(at + 1).and_then(|n| n.parse().ok());
    if value.is_none() {
        usage();
    }
    args.drain(at..at + 2);
    value
}

fn usage() -> ! {
    eprintln!("usage: factorisation RESULT.h5 [--increment N] [--repeats N]");
    std::process::exit(2);
}
