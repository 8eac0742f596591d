//! The stages of a load increment by sample size and number of threads: friends lists,
//! pattern build, a ring membrane's chain, the return map, residual and tangent (the return
//! map and the assembly),
//! numeric Cholesky factorisation, one solve with its factor, and one whole increment by the global solver; and one
//! increment by the relaxation (20 sweeps, the thesis's n_i), which goes grain by grain on one
//! thread.
//!
//! The samples are hexagonal crystals of the sandstone of table 8 between four walls
//! (`samples::crystal_biaxial`), at about 1,000, 10,000 and 100,000 grains: built in
//! milliseconds, where preparing a sprinkled sample of 100,000 grains takes far longer than a
//! benchmark should. Every neighbour touches, so a crystal has three contacts per grain
//! against the four of a dense prepared sample. Its factorisation is slower than that of a
//! prepared sample of the same size (2 ms at 1,000 grains against 0.75 ms for the sand sample
//! in `benches/minimise.rs`): its factor has 1.6 times the entries.
//!
//!     cargo bench --bench stages
//!     cargo bench --bench stages -- "/10000"     # one size

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion};
use faer::sparse::SparseColMatRef;
use grainstat::assembly::{DofMap, Pattern};
use grainstat::contact::Configuration;
use grainstat::geometry::{FriendSet, Membrane, MembraneShape};
use grainstat::samples;
use grainstat::scene::{build_grains, Scene};
use grainstat::simulation::{anchors, IncrementEquations, LoadStep, Simulation};
use grainstat::solver::stats::StageTimers;
use grainstat::solver::{LinearSolver, Potential, SolverConfig, SolverStats, Strategy};
use rayon::{ThreadPool, ThreadPoolBuilder};
use std::path::Path;

/// Crystals of about 1,000, 10,000 and 100,000 grains: (grains, rows, columns).
const SIZES: [(usize, usize, usize); 3] = [(1_000, 41, 25), (10_000, 129, 78), (100_000, 401, 250)];

/// The numbers of threads each stage runs on.
const THREADS: [usize; 2] = [1, 2];

fn scene(rows: usize, columns: usize) -> Scene {
    samples::crystal_biaxial(rows, columns, 1e6, 3e6)
}

fn simulation(scene: &Scene, config: SolverConfig) -> Simulation {
    let grains = build_grains(&scene.grains, Path::new("."), "bench").unwrap();
    Simulation::new(scene, grains, config, "bench").unwrap()
}

/// The friends lists, the unknowns and the pattern of a fresh simulation's state.
fn pattern_of(sim: &Simulation, skin: f64) -> (FriendSet, DofMap, Pattern) {
    let (grains, walls) = (&sim.state.grains, &sim.state.walls);
    let friends = FriendSet::build(grains, walls, skin * grains.mean_radius());
    let dofs = DofMap::new(grains.len(), false, walls, &[], &[]);
    let pattern = Pattern::build(&friends, &dofs, walls, &[]);
    (friends, dofs, pattern)
}

/// The centre of the grains.
fn mean_position(position: &[[f64; 2]]) -> [f64; 2] {
    let n = position.len() as f64;
    let sum = position
        .iter()
        .fold([0.0; 2], |s, p| [s[0] + p[0], s[1] + p[1]]);
    [sum[0] / n, sum[1] / n]
}

fn stages(c: &mut Criterion) {
    let mut group = c.benchmark_group("stages");
    group.sample_size(10);
    for (grains, rows, columns) in SIZES {
        let scene = scene(rows, columns);
        let config = SolverConfig::default();
        let mut sim = simulation(&scene, config.clone());
        let pools: Vec<(usize, ThreadPool)> = THREADS
            .iter()
            .map(|&n| {
                let pool = ThreadPoolBuilder::new().num_threads(n).build().unwrap();
                (n, pool)
            })
            .collect();
        let id = |stage: &str, threads: usize| {
            let s = if threads == 1 { "" } else { "s" };
            BenchmarkId::new(format!("{stage}, {threads} thread{s}"), grains)
        };

        let (grain_set, wall_set) = (&sim.state.grains, &sim.state.walls);
        let skin = config.skin * grain_set.mean_radius();
        for (threads, pool) in &pools {
            group.bench_function(id("friends lists", *threads), |b| {
                b.iter(|| pool.install(|| FriendSet::build(grain_set, wall_set, skin)))
            });
        }
        // A membrane all around the crystal, as the cylinder test's: its chain is found anew
        // at every refreeze of the lag (one thread: the probe rolls grain after grain).
        let ring = Membrane {
            name: "ring".into(),
            shape: MembraneShape::Ring {
                center: mean_position(&grain_set.position),
            },
            pressure: 1e6,
        };
        let (carrying, kept) = (vec![true; grain_set.len()], vec![false; grain_set.len()]);
        group.bench_function(id("membrane chain", 1), |b| {
            b.iter(|| ring.chain(&grain_set.position, &grain_set.radius, &carrying, &kept))
        });
        let (friends, dofs, pattern) = pattern_of(&sim, config.skin);
        for (threads, pool) in &pools {
            group.bench_function(id("pattern build", *threads), |b| {
                b.iter(|| pool.install(|| Pattern::build(&friends, &dofs, wall_set, &[])))
            });
        }

        // The residual and tangent of the first load step at rest.
        let (depth, r_mean) = (sim.depth, sim.mean_radius());
        let material = sim.material.clone();
        let state = &mut sim.state;
        let mut pair_index: Vec<usize> = state
            .contacts
            .contacts
            .iter()
            .map(|c| friends.pairs.binary_search(&c.pair).unwrap())
            .collect();
        let walls = state.walls.len();
        let step = LoadStep {
            normal_move: vec![0.0; walls],
            slide: vec![0.0; walls],
            turn: vec![0.0; walls],
            stress: vec![5e5; walls],
            pressure: Vec::new(),
        };
        let law = material.law();
        let anchors = anchors(&state.grains, &state.walls, &state.contacts.contacts);
        let mut q = Configuration::at_rest(&state.grains, &state.walls);
        let mut kin = Vec::new();
        let mut chains = Vec::new();
        let mut chain_watch = grainstat::geometry::ChainWatch::default();
        let mut loose = Vec::new();
        let u = vec![0.0; dofs.len];
        let mut residual = vec![0.0; dofs.len];
        let mut values = vec![0.0; pattern.nnz()];
        let mut eq = IncrementEquations {
            grains: &state.grains,
            walls: &state.walls,
            contacts: &mut state.contacts.contacts,
            pair_index: &mut pair_index,
            friends: &friends,
            step: &step,
            membranes: &[],
            chains: &mut chains,
            chains_held: false,
            chain_watch: &mut chain_watch,
            carriers: &[],
            anchors: &anchors,
            loose: &mut loose,
            reopened: &[],
            dofs: &dofs,
            pattern: &pattern,
            law: law.as_ref(),
            symmetric: true,
            depth,
            r_mean,
            q: &mut q,
            kin: &mut kin,
            timers: StageTimers::default(),
            f_ref: 0.0,
            stiffness_hint: material.stiffness_hint(r_mean),
            far: false,
            load_scale: 0.0,
            lagged: true,
            frame_correction: Vec::new(),
            rotation_scratch: Default::default(),
            closing_scratch: Default::default(),
            refreeze: false,
            projected: true,
            loads: Vec::new(),
            stale_pattern: false,
            chain_changes: 0,
            consistent: false,
            energy: 0.0,
        };
        // Assembled once here, so the factorisation has its matrix when run alone: the
        // projected Hessian of the increment's potential, the lag frozen where it is.
        eq.evaluate(&u, &mut residual, Some(&mut values), true)
            .unwrap();
        for (threads, pool) in &pools {
            group.bench_function(id("return map", *threads), |b| {
                b.iter(|| pool.install(|| eq.update_contacts().unwrap()))
            });
            group.bench_function(id("residual and tangent", *threads), |b| {
                b.iter(|| {
                    pool.install(|| {
                        eq.evaluate(&u, &mut residual, Some(&mut values), false)
                            .unwrap()
                    })
                })
            });
        }

        // faer's Cholesky takes the pool's threads from PARALLEL_UNKNOWNS unknowns on.
        let matrix = SparseColMatRef::new(pattern.symbolic.as_ref(), &values);
        for (threads, pool) in &pools {
            let mut stats = SolverStats::default();
            let mut linear = LinearSolver::new();
            pool.install(|| linear.analyse(&pattern.symbolic, &mut stats).unwrap());
            group.bench_function(id("factorisation", *threads), |b| {
                b.iter(|| pool.install(|| linear.factorize(matrix, &mut stats).unwrap()))
            });
            // One solve with the factor, as a Newton step and each GMRES iteration make.
            let rhs: Vec<f64> = (0..values.len().min(pattern.symbolic.ncols()))
                .map(|k| (k as f64).sin())
                .collect();
            let mut x = rhs.clone();
            group.bench_function(id("solve", *threads), |b| {
                b.iter(|| {
                    x.copy_from_slice(&rhs);
                    pool.install(|| linear.solve_in_place(&mut x, &mut stats));
                })
            });
        }

        for (threads, pool) in &pools {
            group.bench_function(id("increment, minimise", *threads), |b| {
                b.iter_batched(
                    || simulation(&scene, config.clone()),
                    |mut sim| pool.install(|| sim.run_increment().unwrap()),
                    BatchSize::PerIteration,
                )
            });
        }
        let relaxation = SolverConfig {
            strategy: Strategy::Relaxation,
            ..SolverConfig::default()
        };
        group.bench_function(id("increment, relaxation n_i = 20", 1), |b| {
            b.iter_batched(
                || simulation(&scene, relaxation.clone()),
                |mut sim| sim.run_increment().unwrap(),
                BatchSize::PerIteration,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, stages);
criterion_main!(benches);
