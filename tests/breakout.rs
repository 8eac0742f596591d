//! Breakouts (thesis 4.4.2): a cluster of grains taken out of a running simulation leaves a
//! sample that solves, with the cluster held where it was and counted nowhere; a run
//! resumed after it repeats the uninterrupted one bit for bit; the cylinder report, the
//! pictures and `grainstat info` show it.

mod common;

use grainstat::contact::{BreakMode, BrokenBond, Contact};
use grainstat::estimate::{cylinder_failure, CylinderBreakout};
use grainstat::geometry::Side;
use grainstat::output::plot::plot;
use grainstat::output::{info, read_mechanism, read_state, ResultFile};
use grainstat::run;
use grainstat::samples::cemented_annulus;
use grainstat::scene::build_grains;
use grainstat::simulation::{anchors, membrane_carriers, Simulation};
use grainstat::solver::SolverConfig;
use std::path::Path;

/// The small cemented annulus, fresh.
fn annulus(increments: usize) -> (grainstat::scene::Scene, Simulation) {
    let scene = cemented_annulus(3.0, 8.0, increments);
    let grains = build_grains(&scene.grains, Path::new("."), "annulus").unwrap();
    let sim = Simulation::new(&scene, grains, SolverConfig::default(), "annulus").unwrap();
    (scene, sim)
}

/// The grain on the borehole's surface on the positive x axis and its neighbours on the
/// surface: a cluster that could break out.
fn surface_cluster(sim: &Simulation) -> Vec<usize> {
    let g = &sim.state.grains;
    let distance = |i: usize| g.position[i][0].hypot(g.position[i][1]);
    let inner = (0..g.len()).map(distance).fold(f64::INFINITY, f64::min);
    let r = g.radius[0];
    let surface: Vec<usize> = (0..g.len()).filter(|&i| distance(i) < inner + r).collect();
    let first = *surface
        .iter()
        .max_by(|&&a, &&b| g.position[a][0].total_cmp(&g.position[b][0]))
        .unwrap();
    let near = |i: usize| {
        let d = g.branch(first, i);
        d[0].hypot(d[1]) < 2.1 * r
    };
    surface.into_iter().filter(|&i| near(i)).collect()
}

#[test]
fn a_cluster_taken_out_of_the_borehole_leaves_a_sample_that_solves() {
    let (_, mut sim) = annulus(4);
    let n = sim.state.grains.len();
    for _ in 0..2 {
        sim.run_increment().unwrap();
    }
    let cluster = surface_cluster(&sim);
    assert!(cluster.len() >= 2);
    let out = |i: usize| cluster.contains(&i);
    let bonds_across = (sim.state.contacts.contacts.iter())
        .filter(|c| c.bonded && matches!(c.pair.a, Side::Grain(a) if out(a) != out(c.pair.b)))
        .count();
    assert!(bonds_across > 0);
    let before = sim.state.grains.clone();
    let broken_before = sim.state.contacts.broken_bonds.len();
    let breakout = sim.take_out(&cluster).unwrap();
    let (grains, contacts) = (&sim.state.grains, &sim.state.contacts.contacts);
    let carriers = membrane_carriers(grains, contacts);
    assert!(cluster.iter().all(|&i| !carriers[i]));
    let anchored = anchors(grains, &sim.state.walls, contacts);
    assert!(!anchored.is_empty() && anchored.iter().all(|a| !out(a.grain)));
    assert_eq!(breakout.increment, 3);
    assert_eq!(breakout.grains, cluster);
    assert_eq!(breakout.bonds_broken, bonds_across);
    assert_eq!(breakout.pressure, [sim.state.membranes[0].pressure]);
    assert_eq!(sim.state.breakouts, [breakout]);
    let broken = &sim.state.contacts.broken_bonds[broken_before..];
    assert_eq!(broken.len(), bonds_across);
    assert!(broken
        .iter()
        .all(|b| b.increment == 3 && b.mode == BreakMode::Tension));
    for _ in 0..2 {
        let report = sim.run_increment().unwrap();
        let (error, grain) = sim.equilibrium_error();
        assert!(error < 1e-6, "imbalance {error:e} at grain {grain}");
        let g = &sim.state.grains;
        for &i in &cluster {
            assert!(g.taken_out[i]);
            assert_eq!(g.position[i], before.position[i]);
            assert_eq!(g.displacement[i], before.displacement[i]);
            assert_eq!(g.rotation[i], before.rotation[i]);
        }
        let touching = |c: &grainstat::contact::Contact| {
            out(c.pair.b) || matches!(c.pair.a, Side::Grain(a) if out(a))
        };
        assert!(!sim.state.contacts.contacts.iter().any(touching));
        let m = &report.measurements;
        let expected = 2.0 * m.grain_contacts as f64 / (n - cluster.len()) as f64;
        assert_eq!(m.contacts_per_grain, expected);
    }
    assert_eq!(sim.state.membranes[0].pressure, 5e6);
}

/// Run `sim`'s next increment and write it to `file`, as `run::run_to_end` does with
/// `every = 1`.
fn step(sim: &mut Simulation, file: &mut ResultFile) {
    let report = sim
        .run_increment()
        .unwrap_or_else(|e| panic!("increment {}: {e}", sim.state.increment + 1));
    sim.refresh_workspace().unwrap();
    file.write_increment(&sim.state, &report, &sim.stats)
        .unwrap();
}

#[test]
fn a_run_resumed_after_a_breakout_repeats_the_uninterrupted_one_and_reports_it() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, mut sim) = annulus(5);
    let scene_text = toml::to_string(&scene).unwrap();
    let whole = dir.path().join("whole.h5");
    let mut file = ResultFile::create(&whole, &run::header(&sim, &scene_text, "")).unwrap();
    file.write_increment(&sim.state, &run::initial_report(&sim), &sim.stats)
        .unwrap();
    for _ in 0..2 {
        step(&mut sim, &mut file);
    }
    let cluster = surface_cluster(&sim);
    let breakout = sim.take_out(&cluster).unwrap();
    while !sim.is_finished() {
        step(&mut sim, &mut file);
    }

    // Resumed from the increment the cluster broke out in, and from the one before with the
    // same cluster taken out again (a run killed before it wrote the breakout), each into a
    // file of its own.
    for from in [3, 2] {
        let (header, state) = read_state(&whole, from).unwrap();
        let config = SolverConfig::default();
        let mut resumed = Simulation::resume(&scene, state, header.depth, config).unwrap();
        if from == 2 {
            assert_eq!(resumed.take_out(&cluster).unwrap(), breakout);
        }
        assert_eq!(resumed.state.breakouts, std::slice::from_ref(&breakout));
        let again = dir.path().join(format!("resumed-{from}.h5"));
        let mut file = ResultFile::create(&again, &header).unwrap();
        while !resumed.is_finished() {
            step(&mut resumed, &mut file);
        }
        for k in from + 1..=5 {
            let a = read_state(&whole, k).unwrap().1;
            let b = read_state(&again, k).unwrap().1;
            assert!(a == b, "increment {k} differs, resumed from {from}");
        }
    }

    // The cylinder report: the pressure at the first breakout, the grains broken out.
    let failure = cylinder_failure(&whole).unwrap().expect("a cylinder test");
    let expected = CylinderBreakout {
        increment: 3,
        pressure: 3e6,
        grains: cluster.len(),
        bonds_broken: breakout.bonds_broken,
        debris: false,
    };
    assert_eq!(failure.breakouts, [expected]);
    assert_eq!(failure.first_breakout(), Some(3e6));
    assert_eq!(failure.functional_failure(), Some(3e6));
    let broken_out: Vec<usize> = failure.rows.iter().map(|r| r.broken_out).collect();
    let n = cluster.len();
    assert_eq!(broken_out, [0, 0, 0, n, n, n]);
    let csv = failure.csv();
    assert!(
        csv.lines().next().unwrap().ends_with(",broken_out"),
        "{csv}"
    );
    let row = csv.lines().find(|l| l.starts_with("3,")).unwrap();
    assert!(row.ends_with(&format!(",{n}")), "{row}");
    let markdown = failure.markdown();
    for needle in [
        "| pressure at the first breakout | 3.000e6 | Pa |".to_string(),
        "| pressure at functional failure (the first breakout, else failure as a whole) | 3.000e6 | Pa |"
            .to_string(),
        format!(
            "| 1 | 3 | 3.000e6 | {n} | {} | {n} |",
            breakout.bonds_broken
        ),
    ] {
        assert!(markdown.contains(&needle), "no {needle:?} in:\n{markdown}");
    }

    // The pictures: one of the breakout, and `grainstat info`.
    let plots = dir.path().join("plots");
    let written = plot(&whole, Some(&plots), None).unwrap();
    for name in [
        "breakout-1-00000005.png",
        "cylinder.csv",
        "forces-00000005.png",
    ] {
        assert!(written.contains(&plots.join(name)), "{name} not written");
    }
    let text = info(&whole).unwrap();
    let line = format!("breakouts          1: increment 3 ({n} grains");
    assert!(text.contains(&line), "no {line:?} in:\n{text}");
}

/// `scene` run until it fails into `dir/annulus.h5`, every increment written: the failure,
/// the file and the Newton iterations the run took.
fn run_to_failure(
    scene: &grainstat::scene::Scene,
    dir: &Path,
) -> (run::Failure, std::path::PathBuf, usize) {
    let grains = build_grains(&scene.grains, Path::new("."), "annulus").unwrap();
    let mut sim = Simulation::new(scene, grains, SolverConfig::default(), "annulus").unwrap();
    let path = dir.join("annulus.h5");
    let text = toml::to_string(scene).unwrap();
    let mut file = ResultFile::create(&path, &run::header(&sim, &text, "")).unwrap();
    file.write_increment(&sim.state, &run::initial_report(&sim), &sim.stats)
        .unwrap();
    let failure = match run::run_to_end(&mut sim, Some(&mut file), 1, |_, _| {}) {
        Ok(run::RunEnd::Failed(failure)) => failure,
        other => panic!("expected the annulus to fail, got {other:?}"),
    };
    (failure, path, sim.stats.counters.newton_iterations)
}

/// A cluster that breaks out in the increment that then fails as a whole is on file with
/// the failure, though that increment is not: the small cemented annulus raised in 20-MPa
/// steps breaks a cluster of 4 grains out of its borehole in increment 12, at the 236 MPa
/// the halves of that increment carried last, then fails as a whole (measured). The cylinder
/// report and the pictures show the breakout.
#[test]
fn a_breakout_in_the_increment_that_fails_is_on_file_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let (failure, path, _) = run_to_failure(&common::annulus_to_failure_scene(20), dir.path());
    let last = failure.last_increment;
    let (_, written) = read_state(&path, last).unwrap();
    assert!(written.breakouts.is_empty(), "{:?}", written.breakouts);
    let mechanism = read_mechanism(&path).unwrap().expect("the failure on file");
    assert_eq!(mechanism.increment, last + 1);
    let [breakout] = &mechanism.breakouts[..] else {
        panic!("expected one breakout, got {:?}", mechanism.breakouts);
    };
    assert_eq!(breakout.increment, last + 1);
    assert!(!breakout.grains.iter().any(|g| mechanism.grains.contains(g)));
    // At the highest pressure the failing increment's halves carried in equilibrium.
    let carried = failure.carried.iter().find(|(name, _)| name == "outer");
    let carried = carried.expect("the membrane's pressure").1;
    assert!(carried > written.membranes[0].pressure);
    assert_eq!(breakout.pressure, [carried]);

    let report = cylinder_failure(&path).unwrap().expect("a cylinder test");
    assert_eq!(report.first_breakout(), Some(carried));
    assert_eq!(report.functional_failure(), Some(carried));
    assert_eq!(report.mechanism.map(|m| m.0), Some(mechanism.grains.len()));
    let plots = dir.path().join("plots");
    let written = plot(&path, Some(&plots), None).unwrap();
    let picture = plots.join(format!("breakout-1-{last:08}.png"));
    assert!(written.contains(&picture), "{picture:?} not written");
}

/// A test that ends at its first breakout (`until_breakout`, the thesis's functional
/// failure) ends where the run that goes on finds it: the same annulus in 20-MPa steps, its
/// cluster of 4 grains out in increment 12 at the same pressure, the same grains, and the
/// collapse after it not followed (fewer iterations, nothing carried on as a whole). Without
/// `breakouts` the key is bad input, named with its file and line.
#[test]
fn a_test_that_ends_at_its_first_breakout_finds_it_where_the_whole_run_does() {
    let run_of = |until_breakout: bool| {
        let dir = tempfile::tempdir().unwrap();
        let mut scene = common::annulus_to_failure_scene(20);
        scene.stages[0].until_breakout = until_breakout;
        let (failure, path, iterations) = run_to_failure(&scene, dir.path());
        let mechanism = read_mechanism(&path).unwrap().expect("the failure on file");
        let report = cylinder_failure(&path).unwrap().expect("a cylinder test");
        let pictures = plot(&path, Some(&dir.path().join("plots")), None).unwrap();
        let named = |what: &str| {
            (pictures.iter()).any(|p| p.to_string_lossy().contains(&format!("/{what}-")))
        };
        let drawn = (named("breakout"), named("mechanism"));
        (
            failure,
            mechanism,
            report.first_breakout(),
            iterations,
            drawn,
        )
    };
    let (whole, whole_mechanism, whole_breakout, whole_iterations, _) = run_of(false);
    let (first, mechanism, breakout, iterations, drawn) = run_of(true);
    // Its picture is the breakout's; no mechanism was carried on.
    assert_eq!(drawn, (true, false));
    assert!(
        matches!(first.cause, run::FailureCause::Breakout(_)),
        "{first}"
    );
    assert_eq!(first.increment, whole.increment);
    assert_eq!(breakout, whole_breakout);
    assert!(breakout.is_some());
    assert_eq!(mechanism.breakouts, whole_mechanism.breakouts);
    assert!(mechanism.grains.is_empty() && !whole_mechanism.grains.is_empty());
    assert!(
        iterations < whole_iterations,
        "{iterations} against {whole_iterations}"
    );

    let mut scene = common::annulus_to_failure_scene(20);
    scene.stages[0].breakouts = false;
    scene.stages[0].until_breakout = true;
    let text = toml::to_string(&scene).unwrap();
    let err = grainstat::scene::parse_scene(&text, "annulus.toml").unwrap_err();
    let message = err.to_string();
    let at_line = message.starts_with("annulus.toml:") && message.contains("until_breakout");
    assert!(at_line, "{message}");
}

/// The grain of the borehole's surface nearest its centre, whose bonds have all broken and that touches nothing is
/// free to fall into the borehole: the next increment takes it out as a breakout at the load
/// it commits, and the rest solves on. A grain in the body of the annulus, loose the same way,
/// is caged by its neighbours and stays.
#[test]
fn a_grain_come_loose_at_the_borehole_breaks_out_and_one_in_a_pore_stays() {
    let mut sim = common::annulus_to_failure(40);
    sim.run_increment().unwrap();
    let g = &sim.state.grains;
    let distance = |i: usize| g.position[i][0].hypot(g.position[i][1]);
    let surface = (0..g.len())
        .min_by(|&a, &b| distance(a).total_cmp(&distance(b)))
        .unwrap();
    let r = g.radius[0];
    // A grain in the middle of the annulus's wall (radii 6 r to 16 r), on the negative x axis.
    let inner = (0..g.len())
        .filter(|&i| g.position[i][0] < 0.0 && g.position[i][1].abs() < r)
        .min_by(|&a, &b| {
            (distance(a) - 11.0 * r)
                .abs()
                .total_cmp(&(distance(b) - 11.0 * r).abs())
        })
        .unwrap();
    assert!(distance(inner) > distance(surface) + 4.0 * r);
    // Both made loose: bonds broken, touching nothing.
    let set = &mut *sim.state.contacts;
    for &loose in &[surface, inner] {
        for c in &mut set.contacts {
            if c.bonded && (c.pair.b == loose || c.pair.a == Side::Grain(loose)) {
                (c.bonded, c.broken) = (false, true);
                set.broken_bonds.push(BrokenBond {
                    pair: c.pair,
                    increment: 1,
                    mode: BreakMode::Tension,
                });
            }
        }
    }
    // The surface grain moved half a radius into the borehole; the inner one made 5%
    // smaller, a rattler in its pore.
    let p = sim.state.grains.position[surface];
    let shift = [
        -0.5 * r * p[0] / p[0].hypot(p[1]),
        -0.5 * r * p[1] / p[0].hypot(p[1]),
    ];
    for (v, s) in [0, 1].map(|i| (i, shift[i])) {
        sim.state.grains.displacement[surface][v] += s;
        sim.state.grains.position[surface][v] += s;
    }
    sim.state.grains.radius[inner] *= 0.95;
    let touches = |c: &Contact, i: usize| c.pair.b == i || c.pair.a == Side::Grain(i);
    (sim.state.contacts.contacts).retain(|c| !(touches(c, surface) || touches(c, inner)));
    let report = sim.run_increment().unwrap();
    assert_eq!(report.increment, 2);
    let [breakout] = &sim.state.breakouts[..] else {
        panic!("expected one breakout, got {:?}", sim.state.breakouts);
    };
    assert_eq!(breakout.grains, [surface]);
    assert_eq!(breakout.increment, 2);
    assert_eq!(breakout.pressure, [sim.state.membranes[0].pressure]);
    assert!(sim.state.grains.taken_out[surface] && !sim.state.grains.taken_out[inner]);
    sim.run_increment().unwrap();
    let (error, grain) = sim.equilibrium_error();
    assert!(error < 1e-6, "imbalance {error:e} at grain {grain}");
}
