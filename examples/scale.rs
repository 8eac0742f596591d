//! How time and memory grow with the number of grains: one sandstone crystal per size
//! (`samples::crystal_of_about`, table 8, between four walls), set up, then its first load
//! increment and a short run of three more, each size in a process of its own so that its peak
//! memory is its own. Prints three markdown tables: time and memory by size, where the time
//! of the four increments went, stage by stage, beside the time of one factorisation, and
//! what the simulation holds at the end by part (`Simulation::memory_by_part`) beside the
//! process's peak.
//!
//!     cargo run --release --example scale -- 1000 10000 100000 1000000
//!     cargo run --release --example scale -- --threads 2 10000 100000
//!     cargo run --release --example scale -- --ordering metis 10000 100000
//!
//! Crystals are built in milliseconds; a prepared sample of a million grains is not. A
//! crystal has three contacts per grain against the four of a dense prepared sample.

use grainstat::samples;
use grainstat::scene::build_grains;
use grainstat::simulation::Simulation;
use grainstat::solver::{FillOrdering, SolverConfig};
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// Bytes in a MB, as the peak memory is counted (`VmHWM`'s kB over 1024).
const MB: f64 = 1024.0 * 1024.0;

/// Increments of the short run after the first.
const SHORT_RUN: usize = 3;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut threads = 1usize;
    if let Some(at) = args.iter().position(|a| a == "--threads") {
        threads = match args.get(at + 1).and_then(|n| n.parse().ok()) {
            Some(n) => n,
            None => usage(),
        };
        args.drain(at..at + 2);
    }
    let mut ordering = "auto".to_string();
    if let Some(at) = args.iter().position(|a| a == "--ordering") {
        ordering = args.get(at + 1).cloned().unwrap_or_else(|| usage());
        args.drain(at..at + 2);
    }
    let Ok(fill) = toml::Value::String(ordering.clone()).try_into::<FillOrdering>() else {
        usage()
    };
    if args.first().map(String::as_str) == Some("--one") {
        let grains = args.get(1).and_then(|n| n.parse().ok()).unwrap_or(1000);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.max(1))
            .build()
            .expect("the thread pool");
        let (size, stages, parts) = pool.install(|| measure(grains, threads, fill));
        println!("{size}\n{stages}\n{parts}");
        return;
    }
    let sizes: Vec<usize> = if args.is_empty() {
        vec![1_000, 10_000, 100_000]
    } else {
        match args.iter().map(|a| a.parse()).collect() {
            Ok(sizes) => sizes,
            Err(_) => usage(),
        }
    };
    let me = std::env::current_exe().expect("the example's own path");
    let (mut rows, mut parts) = (Vec::new(), Vec::new());
    for grains in sizes {
        let out = Command::new(&me)
            .args([
                "--threads",
                &threads.to_string(),
                "--ordering",
                &ordering,
                "--one",
                &grains.to_string(),
            ])
            .output()
            .expect("the example runs itself");
        if !out.status.success() {
            eprintln!(
                "{grains} grains failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            std::process::exit(3);
        }
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        let mut lines = text.lines().map(str::to_string);
        rows.push((
            lines.next().unwrap_or_default(),
            lines.next().unwrap_or_default(),
        ));
        parts.push((grains, lines.next().unwrap_or_default()));
    }
    println!(
        "| grains | unknowns | contacts | factor entries | set-up (s) | first increment (s) | \
         Newton iterations | next {SHORT_RUN} increments (s) | peak memory (MB) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (size, _) in &rows {
        println!("{size}");
    }
    println!();
    println!(
        "| grains | threads | detection (s) | return map (s) | assembly (s) | symbolic (s) | \
         factorisations (s) | solves (s) | topology (s) | {} increments (s) | per increment (s) | \
         one factorisation (s) | per increment / one factorisation |",
        SHORT_RUN + 1
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (_, stages) in &rows {
        println!("{stages}");
    }
    println!();
    print_parts(&parts);
}

/// The table of what each size's simulation held at the end, by part: MB and bytes a grain,
/// from the `name=bytes;...` lines of [`measure`] (the grains, then the parts, then the peak).
fn print_parts(sizes: &[(usize, String)]) {
    let parsed: Vec<Vec<(String, f64)>> = sizes
        .iter()
        .map(|(_, line)| {
            line.split(';')
                .filter_map(|item| item.split_once('='))
                .map(|(name, v)| (name.to_string(), v.parse().unwrap_or(f64::NAN)))
                .collect()
        })
        .collect();
    let Some(first) = parsed.first() else { return };
    let header: Vec<String> = sizes.iter().map(|(g, _)| format!("about {g}")).collect();
    println!("| part | {} |", header.join(" | "));
    println!("|---|{}", "---|".repeat(sizes.len()));
    for (k, (name, _)) in first.iter().enumerate().skip(1) {
        let cells: Vec<String> = parsed
            .iter()
            .map(|p| {
                let (grains, bytes) = (p[0].1, p[k].1);
                format!("{:.1} MB, {:.0} B a grain", bytes / MB, bytes / grains)
            })
            .collect();
        println!("| {name} | {} |", cells.join(" | "));
    }
}

fn usage() -> ! {
    eprintln!(
        "usage: scale [--threads N] [--ordering auto|amd|metis] [GRAINS ...]  (whole numbers)"
    );
    std::process::exit(2);
}

/// The two table rows for the crystal of about `grains` grains
/// ([`samples::crystal_of_about`]), run on `threads` threads with the Cholesky in `ordering`,
/// and what its simulation holds at the end by part, with their sum and the peak, as
/// `name=bytes;...` after the grains.
fn measure(grains: usize, threads: usize, ordering: FillOrdering) -> (String, String, String) {
    let scene = samples::crystal_of_about(grains);
    let start = Instant::now();
    let built = build_grains(&scene.grains, Path::new("."), "scale").expect("crystal");
    let config = SolverConfig {
        ordering,
        ..SolverConfig::default()
    };
    let mut sim = Simulation::new(&scene, built, config, "scale").expect("set-up");
    let setup = start.elapsed().as_secs_f64();

    // The stages of the increments alone, not of the set-up.
    let before = sim.stats;
    let start = Instant::now();
    let first = sim.run_increment().expect("first increment");
    let first_time = start.elapsed().as_secs_f64();
    let start = Instant::now();
    for _ in 0..SHORT_RUN {
        sim.run_increment().expect("short run");
    }
    let short = start.elapsed().as_secs_f64();
    let size = format!(
        "| {} | {} | {} | {} | {setup:.2} | {first_time:.2} | {} | {short:.2} | {:.0} |",
        sim.state.grains.len(),
        sim.dofs().len,
        sim.state.contacts.contacts.len(),
        sim.factor_entries(),
        first.newton_iterations,
        peak_memory_mb()
    );
    let (t, t0) = (sim.stats.timers, before.timers);
    let factorisations =
        sim.stats.counters.numeric_factorisations - before.counters.numeric_factorisations;
    let whole = first_time + short;
    let increments = (SHORT_RUN + 1) as f64;
    let one_factorisation = (t.factorisation - t0.factorisation) / factorisations.max(1) as f64;
    let stages = format!(
        "| {} | {threads} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} ({factorisations}) | {:.3} | \
         {:.3} | {whole:.2} | {:.3} | {one_factorisation:.4} | {:.1} |",
        sim.state.grains.len(),
        t.detection - t0.detection,
        t.return_map - t0.return_map,
        t.assembly - t0.assembly,
        t.symbolic - t0.symbolic,
        t.factorisation - t0.factorisation,
        t.solve - t0.solve,
        t.topology - t0.topology,
        whole / increments,
        whole / increments / one_factorisation,
    );
    let by_part = sim.memory_by_part();
    let held: usize = by_part.iter().map(|(_, b)| b).sum();
    let mut parts = format!("grains={};", sim.state.grains.len());
    for (name, bytes) in by_part {
        parts += &format!("{name}={bytes};");
    }
    parts += &format!(
        "all these={held};the process's peak={:.0}",
        peak_memory_mb() * MB
    );
    (size, stages, parts)
}

/// The process's peak resident memory (`VmHWM`), in MB; NaN where /proc does not say.
fn peak_memory_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}
