//! The HDF5 result file: every state written reads back exactly, resume finds the last
//! complete increment, bad files are input errors, and Python can read the layout.

use grainstat::contact::{BreakMode, BrokenBond, Contact, ContactParams, ContactSet, Response};
use grainstat::geometry::{
    Circle, GrainSet, Membrane, MembraneShape, Pair, Side, Wall, WallControl, WallSet,
};
use grainstat::measure::{Measurements, Region, RegionShape};
use grainstat::output::{
    info, read_history, read_increments, read_state, read_summary, ResultFile, RunHeader,
};
use grainstat::simulation::EnergyBalance;
use grainstat::solver::stats::SolverStats;
use grainstat::state::{Breakout, IncrementReport, PeakState, State};
use grainstat::Error;
use std::path::Path;

// One test at a time (`common::serial`): the Python check is a child process that inherits
// the descriptors of files other test threads have open, and with them HDF5's file locks,
// until it exits.
mod common;
use common::serial;

fn wall(name: &str, normal: [f64; 2], offset: f64) -> Wall {
    Wall {
        name: name.into(),
        normal,
        offset,
        pivot: normal.map(|v| v * offset),
        turn: 0.0,
        position: 0.0,
        slide: 0.0,
        control: WallControl::Displacement,
        stress: 0.0,
        length: None,
        friction: 0.25,
        circle: None,
    }
}

fn walls() -> WallSet {
    let mut top = wall("top", [0.0, -1.0], -2.0);
    top.control = WallControl::Stress;
    top.stress = 1.0e5;
    let mut left = wall("left", [1.0, 0.0], 0.0);
    left.friction = f64::INFINITY;
    left.length = Some(2.0);
    WallSet {
        walls: vec![
            wall("bottom", [0.0, 1.0], 0.0),
            wall("right", [-1.0, 0.0], -2.0),
            top,
            left,
        ],
    }
}

fn params(friction: f64) -> ContactParams {
    ContactParams {
        stiffness: 1.0e8,
        kappa: 0.9545454545454546,
        friction,
        strength: 12.5,
    }
}

fn contact(pair: Pair, p: ContactParams, k: f64) -> Contact {
    let shear = 0.1 * k - 3.0e-17;
    let overlap = 1.0e-8 * k + 5e-324;
    Contact {
        pair,
        params: p,
        bonded: false,
        broken: false,
        shear_force0: shear,
        shear_displacement0: 1.0e-7 / 3.0 * k,
        shear_offset: 0.0,
        response: Response {
            normal_force: 10.0 / 3.0 * k,
            shear_force: shear,
            sliding: false,
            dfn_dn: 1.0e8,
            dfs_dn: -2.5e-3 * k,
            dfs_ds: 9.545454545454546e7,
        },
        overlap,
        shear_increment: 0.0,
        start_overlap: overlap,
        lag: Default::default(),
        energy: 0.0,
    }
}

/// A small state after increment `k`: grain-grain and wall contacts, a bonded contact, a
/// broken one still touching, infinite friction and a broken-bond record.
fn state(k: usize) -> State {
    let kf = k as f64;
    // Fixed origins, displacements growing with k (a signed zero included).
    let origin = vec![[0.5, 0.5], [1.5, 0.5], [0.5, 1.5], [1.5, 1.5]];
    let displacement = vec![
        [0.0, 1e-9 * kf],
        [-1e-10 / 3.0 * kf, -0.0],
        [0.0, 0.0],
        [0.0, std::f64::consts::PI * 1e-12 * kf],
    ];
    let radius = vec![0.5, 0.5, 0.4999, 0.5001];
    let mut grains = GrainSet::from_parts(origin, displacement, vec![0.0; 4], radius);
    let position = grains.position.clone();
    grains.rotation = vec![1e-3 * kf, -0.0, 2.0e-300, -1.0 / 7.0 * kf];
    let mut walls = walls();
    walls.walls[2].position = 1e-6 * kf;
    walls.walls[2].stress = 1.0e5 + 1.0e3 * kf;
    walls.walls[1].slide = -2e-7 * kf;

    let mut contacts = vec![
        contact(
            Pair {
                a: Side::Grain(0),
                b: 1,
            },
            params(0.5),
            kf,
        ),
        contact(
            Pair {
                a: Side::Grain(0),
                b: 2,
            },
            params(f64::INFINITY),
            kf + 1.0,
        ),
        contact(
            Pair {
                a: Side::Grain(1),
                b: 3,
            },
            params(0.5),
            kf + 2.0,
        ),
        contact(
            Pair {
                a: Side::Wall(0),
                b: 0,
            },
            params(0.25),
            kf + 3.0,
        ),
        contact(
            Pair {
                a: Side::Wall(3),
                b: 2,
            },
            params(f64::INFINITY),
            kf,
        ),
        contact(
            Pair {
                a: Side::Grain(2),
                b: 3,
            },
            params(0.5),
            kf + 4.0,
        ),
    ];
    contacts[0].response.sliding = true;
    contacts[2].bonded = true;
    contacts[5].broken = true;
    contacts[5].response.sliding = true;
    let broken_bonds = vec![BrokenBond {
        pair: Pair {
            a: Side::Grain(2),
            b: 3,
        },
        increment: 1,
        mode: BreakMode::Shear,
    }];
    // From increment 2 on, grain 3 has broken out (when the top wall carried its stress).
    let breakouts: Vec<Breakout> = (k >= 2)
        .then(|| Breakout {
            increment: 2,
            grains: vec![3],
            bonds_broken: 1,
            debris: false,
            pressure: Vec::new(),
            stress: vec![None, None, Some(1.0e5 + 1.0e3 / 3.0), None],
        })
        .into_iter()
        .collect();
    grains.taken_out[3] = k >= 2;
    State {
        increment: k,
        stage: k / 2,
        stage_increment: k % 2,
        breakouts,
        grains: grains.into(),
        walls,
        contacts: ContactSet {
            contacts,
            broken_bonds,
        }
        .into(),
        friends_reference: position,
        membranes: Vec::new(),
        friends_wall_reference: vec![[0.0, 0.0], [0.0, -1e-7], [1e-6, 0.0], [0.0, 0.0]],
        last_step: vec![1e-9, -2e-9, 3e-5],
    }
}

fn report(s: &State) -> IncrementReport {
    let kf = s.increment as f64;
    IncrementReport {
        increment: s.increment,
        stage: s.stage,
        measurements: Measurements {
            wall_normal_force: vec![100.0 + kf, 50.0, 100.0 + kf, 50.0],
            wall_shear_force: vec![0.0, 1.0, -1.0, kf],
            wall_stress: vec![5.0e4 + kf, 2.5e4, 5.0e4 + kf, f64::NAN],
            wall_shear_stress: vec![0.0, 0.5, -0.5, kf],
            macro_stress: [[1.0e5 + kf, 3.0], [3.5, 2.0e5 - kf]],
            volume: 4.0e-3,
            grain_contacts: 4,
            wall_contacts: 2,
            contacts_per_grain: 2.0,
            bonds: 1,
            broken_bonds: 1,
            mean_rotation: 1e-3 * kf,
            mean_absolute_rotation: 2e-3 * kf,
            region_stress: vec![[[3.0e5 + kf, 1.0], [2.0, 4.0e5]], [[5.0, 6.0], [7.0, -kf]]],
            region_rotation: vec![1e-3 * kf, -2e-3 * kf],
        },
        residual: 1e-9 * kf,
        newton_iterations: 3 + s.increment,
        topology_passes: 2,
        cuts: 0,
        contacts_made: 1,
        contacts_lost: 0,
        bonds_broken: usize::from(s.increment == 1),
        negative_pivots: Some(2),
        energy: EnergyBalance {
            work: 2.0 * kf,
            stored: 10.0 + kf,
            stored_change: kf,
            dissipated: 0.5 * kf,
            bonds_released: 0.25 * kf,
            taken_out: 0.125 * kf,
        },
        // A bond broken within increment 2 left its end below its peak.
        peak: (s.increment == 2).then(|| PeakState {
            wall_position: vec![0.0, 1e-6, -2e-6, 3e-6],
            wall_stress: vec![6.0e4, 2.5e4, 6.0e4, f64::NAN],
            macro_stress: [[1.0e5, 3.0], [3.5, 3.0e5]],
        }),
    }
}

fn stats(k: usize) -> SolverStats {
    let mut s = SolverStats::default();
    s.timers.solve = 0.125 * k as f64;
    s.timers.assembly = 0.5;
    s.counters.increments = k;
    s.counters.newton_iterations = 4 * k;
    s
}

fn header(s: &State) -> RunHeader {
    RunHeader {
        scene_name: "tiny box".into(),
        scene_text: "name = \"tiny box\"\n[material]\nlaw = \"linear\"\n".into(),
        solver_text: "tolerance = 1e-8\n".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        depth: 1.0,
        radius: s.grains.radius.clone(),
        walls: RunHeader::walls_of(&s.walls),
        fixed_rotations: false,
        law: "linear".into(),
        membranes: Vec::new(),
        regions: vec![
            Region {
                name: "middle".into(),
                shape: RegionShape::Rectangle {
                    min: [0.0, 0.5],
                    max: [1.0, 1.5],
                },
            },
            Region {
                name: "ring".into(),
                shape: RegionShape::Ring {
                    center: [1.0, 1.0],
                    inner: 0.5,
                    outer: 1.0,
                },
            },
        ],
    }
}

fn write_three(path: &Path) -> Vec<State> {
    let states: Vec<State> = (1..=3).map(state).collect();
    let mut file = ResultFile::create(path, &header(&states[0])).expect("create");
    for s in &states {
        file.write_increment(s, &report(s), &stats(s.increment))
            .expect("write increment");
    }
    file.write_summary(&stats(3)).expect("summary");
    states
}

fn history_increments(path: &Path) -> Vec<i64> {
    let f = hdf5::File::open(path).expect("open");
    f.dataset("history/increment")
        .and_then(|d| d.read_raw::<i64>())
        .expect("history")
}

/// A summary written before the Newton solver was removed has its settling and reuse counts
/// too: they are left unread, and the rest reads as it was written.
#[test]
fn a_summary_with_the_newton_solvers_counters_reads() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("old.h5");
    write_three(&path);
    {
        let f = hdf5::File::open_rw(&path).expect("open");
        let g = f.group("summary").expect("summary");
        for name in ["settling_steps", "factorisations_reused"] {
            let a = g.new_attr::<i64>().create(name).expect("attribute");
            a.write_scalar(&7i64).expect("written");
        }
        let a = g
            .new_attr::<f64>()
            .create("time_settling")
            .expect("attribute");
        a.write_scalar(&0.5f64).expect("written");
    }
    assert_eq!(read_summary(&path).unwrap(), Some(stats(3)));
    assert!(info(&path).is_ok());
}

#[test]
fn every_increment_reads_back_exactly() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub/dir/run.h5");
    let states = write_three(&path);
    assert_eq!(read_increments(&path).unwrap(), vec![1, 2, 3]);
    for s in &states {
        let (h, back) = read_state(&path, s.increment).unwrap();
        assert_eq!(h, header(s));
        assert_eq!(&back, s);
        // Bit for bit, signed zeros and subnormals included.
        assert_eq!(back.grains.rotation[1].to_bits(), (-0.0f64).to_bits());
    }
    assert_eq!(read_summary(&path).unwrap(), Some(stats(3)));
    assert_eq!(history_increments(&path), vec![1, 2, 3]);
    assert!(matches!(read_state(&path, 7), Err(Error::Input(_))));
    // The rotations and the regions' stresses go to `/history`, one row per increment.
    let history = read_history(&path).unwrap();
    assert_eq!(history.float("mean_rotation"), [1e-3, 2e-3, 3e-3]);
    assert_eq!(history.float("mean_absolute_rotation"), [2e-3, 4e-3, 6e-3]);
    assert_eq!(history.float("energy_work"), [2.0, 4.0, 6.0]);
    assert_eq!(history.float("energy_stored"), [11.0, 12.0, 13.0]);
    assert_eq!(history.float("energy_dissipated"), [0.5, 1.0, 1.5]);
    assert_eq!(history.float("energy_bonds_released"), [0.25, 0.5, 0.75]);
    assert_eq!(history.float("energy_taken_out"), [0.125, 0.25, 0.375]);
    assert_eq!(history.float("energy_imbalance"), [0.0625, 0.0625, 0.0625]);
    // Each increment's peak: its end, but where a part of it was higher.
    assert_eq!(
        history.float("macro_stress_yy_peak"),
        [2.0e5 - 1.0, 3.0e5, 2.0e5 - 3.0]
    );
    assert_eq!(history.float("macro_stress_xy_peak"), [3.0, 3.0, 3.0]);
    let peak_stress = history.wall("wall_stress_peak");
    assert_eq!(peak_stress[1][..3], [6.0e4, 2.5e4, 6.0e4]);
    assert_eq!(peak_stress[2][..3], [5.0e4 + 3.0, 2.5e4, 5.0e4 + 3.0]);
    assert_eq!(
        history.wall("wall_position_peak")[1],
        [0.0, 1e-6, -2e-6, 3e-6]
    );
    assert_eq!(
        history.wall("wall_position_peak")[2],
        history.wall("wall_position")[2]
    );
    assert_eq!(history.region("region_stress_xx")[1], [3.0e5 + 2.0, 5.0]);
    assert_eq!(history.region("region_stress_xy")[2], [1.0, 6.0]);
    assert_eq!(history.region("region_stress_yx")[2], [2.0, 7.0]);
    assert_eq!(history.region("region_stress_yy")[2], [4.0e5, -3.0]);

    let text = info(&path).unwrap();
    for needle in [
        "tiny box",
        "increments  3 written, 1 .. 3",
        "top",
        "macro stress",
        "breakouts          1: increment 2 (1 grain, 1 bond broken; top 1.0033e5 Pa)",
    ] {
        assert!(text.contains(needle), "info lacks {needle:?}:\n{text}");
    }
}

#[test]
fn resume_takes_the_last_complete_increment() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.h5");
    let states = write_three(&path);
    {
        let f = hdf5::File::open_rw(&path).unwrap();
        f.group("increments/00000003")
            .unwrap()
            .delete_attr("complete")
            .unwrap();
    }
    assert_eq!(read_increments(&path).unwrap(), vec![1, 2]);
    let (mut file, h, resumed) = ResultFile::open_for_resume(&path).unwrap();
    assert_eq!(h, header(&states[0]));
    assert_eq!(resumed, states[1]);
    assert_eq!(history_increments(&path), vec![1, 2]);

    // Going on from there writes increment 3 again, as the uninterrupted run did.
    let s = &states[2];
    file.write_increment(s, &report(s), &stats(3)).unwrap();
    drop(file);
    assert_eq!(read_increments(&path).unwrap(), vec![1, 2, 3]);
    assert_eq!(&read_state(&path, 3).unwrap().1, s);
    assert_eq!(history_increments(&path), vec![1, 2, 3]);

    // Rewriting an increment replaces it and its history rows.
    let (mut file, _, _) = ResultFile::open_for_resume(&path).unwrap();
    file.write_increment(&states[1], &report(&states[1]), &stats(2))
        .unwrap();
    drop(file);
    assert_eq!(history_increments(&path), vec![1, 2]);
    assert_eq!(&read_state(&path, 2).unwrap().1, &states[1]);
}

/// A reader that keeps the file open keeps its version while the run writes on: the run does
/// not write to a file held open (HDF5 will not open it for writing), it makes a new twin.
#[test]
fn a_reader_keeps_its_version_while_the_run_writes_on() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.h5");
    let states: Vec<State> = (1..=5).map(state).collect();
    let mut file = ResultFile::create(&path, &header(&states[0])).unwrap();
    for s in &states[..2] {
        file.write_increment(s, &report(s), &stats(s.increment))
            .unwrap();
    }
    let reader = hdf5::File::open(&path).unwrap();
    let mut held = std::fs::File::open(&path).unwrap();
    let before = std::fs::read(&path).unwrap();
    for s in &states[2..] {
        file.write_increment(s, &report(s), &stats(s.increment))
            .unwrap();
    }
    let mut after = Vec::new();
    std::io::Read::read_to_end(&mut held, &mut after).unwrap();
    assert!(after == before, "the file the reader holds was written to");
    assert_eq!(reader.group("increments").unwrap().len(), 2);
    drop(reader);
    drop(file);
    assert_eq!(read_increments(&path).unwrap(), vec![1, 2, 3, 4, 5]);
    for s in &states {
        assert_eq!(&read_state(&path, s.increment).unwrap().1, s);
    }
    assert!(
        !dir.path().join("run.h5.writing").exists(),
        "the twin outlived the run"
    );
}

/// Rewrite every `/history` dataset of `path` as files written before it was stored plain
/// have it: chunked, shuffled and deflated.
fn compress_history(path: &Path) {
    let f = hdf5::File::open_rw(path).unwrap();
    let h = f.group("history").unwrap();
    for name in h.member_names().unwrap() {
        let ds = h.dataset(&name).unwrap();
        let shape = ds.shape();
        // Tables of no columns (no membranes here) stay as they are: none to compress.
        if shape[1..].contains(&0) {
            continue;
        }
        let extents: Vec<hdf5::Extent> = shape
            .iter()
            .enumerate()
            .map(|(d, &n)| match d {
                0 => hdf5::Extent::resizable(n),
                _ => hdf5::Extent::fixed(n),
            })
            .collect();
        let mut chunk = shape.clone();
        chunk[0] = 256;
        let builder = || {
            h.new_dataset_builder()
                .chunk(chunk.clone())
                .shuffle()
                .deflate(4)
        };
        if ds.dtype().unwrap().is::<i64>() {
            let data = ds.read_raw::<i64>().unwrap();
            h.unlink(&name).unwrap();
            let ds = builder()
                .empty::<i64>()
                .shape(extents)
                .create(name.as_str());
            ds.unwrap().write_raw(&data).unwrap();
        } else {
            let data = ds.read_raw::<f64>().unwrap();
            h.unlink(&name).unwrap();
            let ds = builder()
                .empty::<f64>()
                .shape(extents)
                .create(name.as_str());
            ds.unwrap().write_raw(&data).unwrap();
        }
    }
}

/// A file whose `/history` was written compressed (before it was stored plain) resumes:
/// the next rows go to its compressed datasets.
#[test]
fn a_file_with_a_compressed_history_resumes() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.h5");
    let mut states = write_three(&path);
    compress_history(&path);
    let f = hdf5::File::open(&path).unwrap();
    assert!(f.dataset("history/wall_stress").unwrap().filters().len() == 2);
    drop(f);
    let (mut file, _, resumed) = ResultFile::open_for_resume(&path).unwrap();
    assert_eq!(resumed, states[2]);
    states.push(state(4));
    let s = &states[3];
    file.write_increment(s, &report(s), &stats(4)).unwrap();
    drop(file);
    assert_eq!(read_increments(&path).unwrap(), vec![1, 2, 3, 4]);
    for s in &states {
        assert_eq!(&read_state(&path, s.increment).unwrap().1, s);
    }
    let history = read_history(&path).unwrap();
    assert_eq!(history.int("increment"), [1, 2, 3, 4]);
    assert_eq!(history.float("mean_rotation"), [1e-3, 2e-3, 3e-3, 4e-3]);
    assert_eq!(history.wall("wall_stress")[3][0], 5.0e4 + 4.0);
}

#[test]
fn empty_and_large_sets_work() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    // No contacts, no walls, no friends lists yet.
    let path = dir.path().join("empty.h5");
    let mut s = state(0);
    s.contacts = ContactSet::default().into();
    s.walls = WallSet::default();
    s.friends_reference.clear();
    s.friends_wall_reference.clear();
    let mut r = report(&s);
    r.measurements = Measurements::default();
    let mut file = ResultFile::create(&path, &header(&s)).unwrap();
    file.write_increment(&s, &r, &SolverStats::default())
        .unwrap();
    drop(file);
    assert_eq!(read_state(&path, 0).unwrap().1, s);
    assert!(info(&path).is_ok());

    // Enough grains and contacts that the header's datasets are chunked and compressed;
    // the increment's are written plain.
    let path = dir.path().join("large.h5");
    let n = 1500;
    let position: Vec<[f64; 2]> = (0..n)
        .map(|i| [i as f64 * 1.0001, (i % 7) as f64 / 3.0])
        .collect();
    let mut s = state(5);
    s.grains = GrainSet::new(position.clone(), vec![0.5; n]).into();
    s.grains.rotation = (0..n).map(|i| (i as f64).sin() * 1e-3).collect();
    s.grains.taken_out[3] = true;
    s.contacts.contacts = (0..n - 1)
        .map(|i| {
            contact(
                Pair {
                    a: Side::Grain(i),
                    b: i + 1,
                },
                params(0.5),
                i as f64,
            )
        })
        .collect();
    s.contacts.contacts.push(contact(
        Pair {
            a: Side::Wall(1),
            b: n - 1,
        },
        params(0.25),
        1.0,
    ));
    s.friends_reference = position;
    let mut file = ResultFile::create(&path, &header(&s)).unwrap();
    file.write_increment(&s, &report(&s), &stats(5)).unwrap();
    drop(file);
    assert_eq!(read_state(&path, 5).unwrap().1, s);
    let f = hdf5::File::open(&path).unwrap();
    assert!(f.dataset("grains/radius").unwrap().is_chunked());
    let pair = f.dataset("increments/00000005/contacts/pair").unwrap();
    assert!(!pair.is_chunked());
    assert_eq!(pair.shape(), vec![n, 2]);
}

#[test]
fn bad_files_are_input_errors() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.h5");
    let garbage = dir.path().join("garbage.h5");
    std::fs::write(&garbage, b"this is not an HDF5 file at all\n").unwrap();
    let foreign = dir.path().join("foreign.h5");
    hdf5::File::create(&foreign)
        .unwrap()
        .create_group("x")
        .unwrap();
    for p in [&missing, &garbage, &foreign] {
        let name = p.display().to_string();
        match ResultFile::open_for_resume(p) {
            Err(Error::Input(e)) => assert_eq!(e.file, name),
            other => panic!(
                "{name}: expected an input error, got {:?}",
                other.map(|_| ())
            ),
        }
        assert!(matches!(read_increments(p), Err(Error::Input(_))));
        assert!(matches!(read_state(p, 1), Err(Error::Input(_))));
        assert!(matches!(info(p), Err(Error::Input(_))));
    }

    // A result file whose only increment is incomplete has nothing to resume from.
    let partial = dir.path().join("partial.h5");
    let s = state(1);
    let mut file = ResultFile::create(&partial, &header(&s)).unwrap();
    file.write_increment(&s, &report(&s), &stats(1)).unwrap();
    drop(file);
    hdf5::File::open_rw(&partial)
        .unwrap()
        .group("increments/00000001")
        .unwrap()
        .delete_attr("complete")
        .unwrap();
    match ResultFile::open_for_resume(&partial) {
        Err(Error::Input(e)) => assert!(e.message.contains("no complete increment"), "{e}"),
        other => panic!("expected an input error, got {:?}", other.map(|_| ())),
    }
    assert!(matches!(read_state(&partial, 1), Err(Error::Input(_))));

    // A result file with a damaged increment: an error, not a panic.
    let damaged = dir.path().join("damaged.h5");
    let mut file = ResultFile::create(&damaged, &header(&s)).unwrap();
    file.write_increment(&s, &report(&s), &stats(1)).unwrap();
    drop(file);
    hdf5::File::open_rw(&damaged)
        .unwrap()
        .unlink("increments/00000001/contacts/params")
        .unwrap();
    assert!(matches!(read_state(&damaged, 1), Err(Error::Input(_))));
    assert!(matches!(
        ResultFile::open_for_resume(&damaged),
        Err(Error::Input(_))
    ));
}

/// Files from before grains were taken out have no `breakouts`: none is. Breakouts that name
/// a grain there is not, or one grain twice, are bad input.
#[test]
fn breakouts_read_back_and_are_checked() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, s: &State| {
        let path = dir.path().join(name);
        let mut file = ResultFile::create(&path, &header(s)).unwrap();
        file.write_increment(s, &report(s), &stats(2)).unwrap();
        path
    };
    let s = state(2);
    let old = write("old.h5", &s);
    hdf5::File::open_rw(&old)
        .unwrap()
        .unlink("increments/00000002/breakouts")
        .unwrap();
    let (_, back) = read_state(&old, 2).unwrap();
    assert!(back.breakouts.is_empty() && !back.grains.taken_out.contains(&true));

    let absent = write("absent.h5", &s);
    hdf5::File::open_rw(&absent)
        .unwrap()
        .dataset("increments/00000002/breakouts/grains")
        .unwrap()
        .write_raw(&[9i64][..])
        .unwrap();
    let mut twice = s.clone();
    twice.breakouts.push(twice.breakouts[0].clone());
    let twice = write("twice.h5", &twice);
    for (path, message) in [
        (absent, "names grain 9"),
        (twice, "grain 3 is taken out twice"),
    ] {
        match read_state(&path, 2) {
            Err(Error::Input(e)) => assert!(e.message.contains(message), "{e}"),
            other => panic!("expected an input error, got {:?}", other.map(|_| ())),
        }
    }
}

const PYTHON_CHECK: &str = r#"
import sys, math
import h5py
import numpy as np

with h5py.File(sys.argv[1], "r") as f:
    assert f.attrs["format"] == "grainstat-result", f.attrs["format"]
    assert f.attrs["scene_name"] == "tiny box"
    assert f["run/scene"][()].decode().startswith('name = "tiny box"')
    assert list(f["walls/name"].asstr()[...]) == ["bottom", "right", "top", "left"]
    assert list(f["walls/control"].asstr()[...]) == ["displacement", "displacement", "stress", "displacement"]
    assert math.isinf(f["walls/friction"][3]) and math.isnan(f["walls/length"][0])
    assert f["grains/radius"].shape == (4,)
    names = sorted(f["increments"])
    assert names == ["00000001", "00000002", "00000003"], names
    g = f["increments/00000003"]
    assert g.attrs["complete"] == 1 and g.attrs["increment"] == 3
    assert g["grains/position"].shape == (4, 2) and g["grains/position"].dtype == np.float64
    assert (g["grains/origin"][...] + g["grains/displacement"][...] == g["grains/position"][...]).all()
    pair = g["contacts/pair"][...]
    assert pair.shape == (6, 2) and pair.dtype == np.int64
    assert list(pair[3]) == [-1, 0] and list(pair[4]) == [-4, 2]
    assert list(g["contacts/state"][...]) == [1, 0, 2, 0, 0, 3]
    assert np.isinf(g["contacts/params"][1, 2])
    assert g["walls/position"].shape == (4,) and g["walls/position"][2] == 1e-6 * 3.0
    assert g["macro_stress"].shape == (2, 2) and g["macro_stress"][0, 0] == 1.0e5 + 3
    assert g["broken_bonds"].shape == (1, 4) and list(g["broken_bonds"][0]) == [2, 3, 1, 1]
    b = g["breakouts"]
    assert list(b["increment"][...]) == [2] and list(b["grain_count"][...]) == [1]
    assert list(b["grains"][...]) == [3] and list(b["bonds_broken"][...]) == [1]
    assert b["membrane_pressure"].shape == (1, 0) and b["wall_stress"].shape == (1, 4)
    assert np.isnan(b["wall_stress"][0, 0]) and b["wall_stress"][0, 2] == 1.0e5 + 1.0e3 / 3.0
    assert "breakouts" in f["increments/00000002"] and len(f["increments/00000001/breakouts/grains"]) == 0
    h = f["history"]
    assert list(h["increment"][...]) == [1, 2, 3]
    assert h["wall_stress"].shape == (3, 4) and h["wall_stress"][2, 0] == 5.0e4 + 3
    assert list(h["macro_stress_xx"][...]) == [1.0e5 + 1, 1.0e5 + 2, 1.0e5 + 3]
    assert f["summary"].attrs["increments"] == 3 and f["summary"].attrs["time_solve"] == 0.375
print("python ok")
"#;

#[test]
fn python_reads_the_layout() {
    let _serial = serial();
    let python = "/usr/bin/python3";
    let has_h5py = std::process::Command::new(python)
        .args(["-c", "import h5py"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_h5py {
        eprintln!("skipping python_reads_the_layout: {python} cannot import h5py");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.h5");
    write_three(&path);
    let script = dir.path().join("check.py");
    std::fs::write(&script, PYTHON_CHECK).unwrap();
    let out = std::process::Command::new(python)
        .arg(&script)
        .arg(&path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "python check failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn circular_walls_and_membranes_read_back() {
    let _guard = serial();
    let ring = Wall {
        normal: [0.0; 2],
        position: 1.5e-6,
        circle: Some(Circle {
            center: [1.0, 1.0],
            radius: 1.25,
            grains_inside: true,
            moves: None,
        }),
        ..wall("ring", [0.0; 2], 0.0)
    };
    let plug = Wall {
        circle: Some(Circle {
            center: [1.0, 1.0],
            radius: 0.25,
            grains_inside: false,
            moves: Some([0.6, -0.8]),
        }),
        ..ring.clone()
    };
    let walls = WallSet {
        walls: vec![ring, plug],
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("circles.h5");
    let mut state = state(1);
    state.walls = walls;
    state.friends_wall_reference = vec![[0.0; 2]; 2];
    state
        .contacts
        .contacts
        .retain(|c| matches!(c.pair.a, Side::Grain(_)));
    state.membranes = vec![
        Membrane {
            name: "right".into(),
            shape: MembraneShape::Side {
                outward: [1.0, 0.0],
            },
            pressure: 2.5e5,
        },
        Membrane {
            name: "outer".into(),
            shape: MembraneShape::Ring { center: [1.0, 1.0] },
            pressure: 1.0e6,
        },
    ];
    let header = RunHeader {
        walls: RunHeader::walls_of(&state.walls),
        membranes: state.membranes.clone(),
        ..header(&state)
    };
    let mut file = ResultFile::create(&path, &header).unwrap();
    file.write_increment(&state, &report(&state), &SolverStats::default())
        .unwrap();
    drop(file);
    let (back_header, back) = read_state(&path, 1).unwrap();
    assert_eq!(back_header.walls, header.walls);
    assert_eq!(back.walls, state.walls);
    assert_eq!(back.membranes, state.membranes);
}
