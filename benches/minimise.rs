//! The pieces of one iteration of the minimisation (`strategy = "minimise"`) on a prepared
//! sample: one evaluation of the potential with its Hessian (refrozen or not) and one without
//! (a line search's), the factorisation of the regularised Hessian by the solver and by faer
//! alone on the same matrix (its own ordering and permutation, buffers kept; simplicial or
//! supernodal as faer chooses, and in supernodes), and one solve.
//! The potential is the one the first iteration of the scene's next increment meets. Times
//! are the thread's CPU time: the machines this runs on are shared.
//!
//!     grainstat generate examples/sample-sand.toml -o samples/sand.h5
//!     cargo bench --bench minimise
//!     MINIMISE_BENCH_SCENE=other-scene.toml cargo bench --bench minimise
//!     MINIMISE_BENCH_CRYSTAL=100000 cargo bench --bench minimise
//!
//! `MINIMISE_BENCH_CRYSTAL=N` takes the sandstone crystal of about N grains that
//! `examples/scale.rs` times (`samples::crystal_of_about`).

use criterion::measurement::{Measurement, ValueFormatter, WallTime};
use criterion::{criterion_group, criterion_main, Criterion};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::SparseColMatRef;
use faer::{Par, Side};
use grainstat::run;
use grainstat::samples;
use grainstat::scene::{load_scene, load_solver};
use grainstat::solver::minimise::regularise;
use grainstat::solver::{FillOrdering, LinearSolver, SolverStats};
use std::path::Path;
use std::time::Duration;

/// The scene benchmarked unless `MINIMISE_BENCH_SCENE` names another.
const SCENE: &str = "examples/biaxial-sand-steps.toml";

fn minimise(c: &mut Criterion<CpuTime>) {
    // One thread, as the benchmark run's `--threads 1`: the work stays on this thread.
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .unwrap();
    let scene_path = std::env::var("MINIMISE_BENCH_SCENE").unwrap_or(SCENE.into());
    let scene_path = Path::new(&scene_path);
    let crystal = std::env::var("MINIMISE_BENCH_CRYSTAL").ok();
    let scene = match crystal.as_deref().map(str::parse::<usize>) {
        Some(Ok(grains)) => samples::crystal_of_about(grains),
        Some(Err(_)) => panic!("MINIMISE_BENCH_CRYSTAL: a number of grains"),
        None => load_scene(scene_path).unwrap().0,
    };
    let (config, _) = load_solver(Path::new("solvers/minimise.toml")).unwrap();
    let mut sim = match run::start(&scene, scene_path, config) {
        Ok(sim) => sim,
        Err(e) => {
            eprintln!("{}: {e} (make its sample first)", scene_path.display());
            return;
        }
    };
    let grains = sim.state.grains.len();
    let mut group = c.benchmark_group("minimise");
    group.sample_size(20);
    {
        sim.with_next_potential(|eq, pattern| {
            let n = pattern.diagonal.len();
            let u = vec![0.0; n];
            let mut residual = vec![0.0; n];
            let mut values = vec![0.0; pattern.nnz()];
            eq.evaluate(&u, &mut residual, Some(&mut values), true)
                .unwrap();
            let name = |stage: &str| format!("{stage}/{grains}");
            group.bench_function(name("evaluation, Hessian, refrozen"), |b| {
                b.iter(|| eq.evaluate(&u, &mut residual, Some(&mut values), true))
            });
            group.bench_function(name("evaluation, Hessian"), |b| {
                b.iter(|| eq.evaluate(&u, &mut residual, Some(&mut values), false))
            });
            group.bench_function(name("evaluation, residual"), |b| {
                b.iter(|| eq.evaluate(&u, &mut residual, None, false))
            });

            let mut shift = vec![0.0; n];
            regularise(eq, &values, &pattern.diagonal, 1e-4, &mut shift);
            let matrix = SparseColMatRef::new(pattern.symbolic.as_ref(), &values);
            let mut stats = SolverStats::default();
            // In AMD's order at every size, as faer alone below is: the same factor.
            let mut linear = LinearSolver::in_order(FillOrdering::Amd);
            linear.analyse(&pattern.symbolic, &mut stats).unwrap();
            group.bench_function(name("factorisation"), |b| {
                b.iter(|| {
                    linear
                        .factorize_shifted(matrix, &shift, &mut stats)
                        .unwrap()
                })
            });
            let mut x = residual.clone();
            group.bench_function(name("solve"), |b| {
                b.iter(|| {
                    x.copy_from_slice(&residual);
                    linear.solve_in_place(&mut x, &mut stats)
                })
            });

            // faer alone on the same matrix, regularised.
            let mut regularised = values.clone();
            for (&slot, add) in pattern.diagonal.iter().zip(&shift) {
                regularised[slot] += add;
            }
            let matrix = SparseColMatRef::new(pattern.symbolic.as_ref(), &regularised);
            // faer's own choice (simplicial below some 5,000 grains), and in supernodes as
            // the solver factorises.
            for (label, threshold) in [
                ("faer alone", SupernodalThreshold::AUTO),
                (
                    "faer alone in supernodes",
                    SupernodalThreshold::FORCE_SUPERNODAL,
                ),
            ] {
                let params = CholeskySymbolicParams {
                    supernodal_flop_ratio_threshold: threshold,
                    ..Default::default()
                };
                let symbolic = factorize_symbolic_cholesky(
                    pattern.symbolic.as_ref(),
                    Side::Lower,
                    SymmetricOrdering::Amd,
                    params,
                )
                .unwrap();
                let mut l_values = vec![0.0; symbolic.len_val()];
                let mut buffer = MemBuffer::new(
                    symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
                );
                group.bench_function(name(&format!("factorisation, {label}")), |b| {
                    b.iter(|| {
                        symbolic
                            .factorize_numeric_llt(
                                &mut l_values,
                                matrix,
                                Side::Lower,
                                Default::default(),
                                Par::Seq,
                                MemStack::new(&mut buffer),
                                Default::default(),
                            )
                            .map(|_| ())
                            .unwrap()
                    })
                });
            }
        })
        .unwrap()
    }
    group.finish();
}

/// The CPU time of the calling thread.
struct CpuTime;

/// Formats a time as criterion formats the wall time.
static FORMATTER: WallTime = WallTime;

fn thread_cpu_time() -> Duration {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec to write into.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    Duration::new(t.tv_sec as u64, t.tv_nsec as u32)
}

impl Measurement for CpuTime {
    type Intermediate = Duration;
    type Value = Duration;

    fn start(&self) -> Duration {
        thread_cpu_time()
    }
    fn end(&self, start: Duration) -> Duration {
        thread_cpu_time() - start
    }
    fn add(&self, a: &Duration, b: &Duration) -> Duration {
        *a + *b
    }
    fn zero(&self) -> Duration {
        Duration::ZERO
    }
    fn to_f64(&self, value: &Duration) -> f64 {
        value.as_nanos() as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        FORMATTER.formatter()
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(CpuTime);
    targets = minimise
}
criterion_main!(benches);
