//! How time and memory grow with the number of grains: one sandstone crystal per size
//! (`samples::crystal_of_about`, table 8, between four walls), set up, then its first load
//! increment and a short run of three more, each size in a process of its own so that its peak
//! memory is its own. Prints three markdown tables: time and memory by size, with each
//! increment's time, Newton iterations and factorisations; where the time of the four
//! increments went, stage by stage, beside the time of one factorisation; and what the
//! simulation holds at the end by part (`Simulation::memory_by_part`) beside the process's
//! peak. The first increment
//! starts from first touch and the third is the first of the second stage; the second and
//! fourth are loaded increments as a long run has most of. `--no-indicator` turns the
//! stability indicator off (its own factorisation each increment).
//!
//!     cargo run --release --example scale -- 1000 10000 100000 1000000
//!     cargo run --release --example scale -- --threads 2 10000 100000
//!     cargo run --release --example scale -- --ordering metis 10000 100000
//!     cargo run --release --example scale -- --no-indicator 100000
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
    grainstat::give_back_large_blocks();
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
    let indicator = match args.iter().position(|a| a == "--no-indicator") {
        Some(at) => {
            args.remove(at);
            false
        }
        None => true,
    };
    if args.first().map(String::as_str) == Some("--one") {
        let grains = args.get(1).and_then(|n| n.parse().ok()).unwrap_or(1000);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.max(1))
            .build()
            .expect("the thread pool");
        let (size, stages, parts) = pool.install(|| measure(grains, threads, fill, indicator));
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
        let mut command = Command::new(&me);
        if !indicator {
            command.arg("--no-indicator");
        }
        let out = command
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
        "| grains | unknowns | contacts | factor entries | set-up (s) | each increment: s \
         (Newton iterations, factorisations in s) | peak memory (MB) |"
    );
    println!("|---|---|---|---|---|---|---|");
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
        "usage: scale [--threads N] [--ordering auto|amd|metis] [--no-indicator] [GRAINS ...]  \
         (whole numbers)"
    );
    std::process::exit(2);
}

/// The two table rows for the crystal of about `grains` grains
/// ([`samples::crystal_of_about`]), run on `threads` threads with the Cholesky in `ordering`
/// and the stability indicator on or off, and what its simulation holds at the end by part,
/// with their sum and the peak, as `name=bytes;...` after the grains.
fn measure(
    grains: usize,
    threads: usize,
    ordering: FillOrdering,
    stability_indicator: bool,
) -> (String, String, String) {
    let scene = samples::crystal_of_about(grains);
    let start = Instant::now();
    let built = build_grains(&scene.grains, Path::new("."), "scale").expect("crystal");
    let config = SolverConfig {
        ordering,
        stability_indicator,
        ..SolverConfig::default()
    };
    let mut sim = Simulation::new(&scene, built, config, "scale").expect("set-up");
    let setup = start.elapsed().as_secs_f64();

    // The stages of the increments alone, not of the set-up.
    let before = sim.stats;
    let mut each = Vec::new();
    let mut whole = 0.0;
    for _ in 0..=SHORT_RUN {
        let (start, at) = (Instant::now(), sim.stats);
        let report = sim.run_increment().expect("an increment");
        let time = start.elapsed().as_secs_f64();
        whole += time;
        let made = sim.stats.counters.numeric_factorisations - at.counters.numeric_factorisations;
        let took = sim.stats.timers.factorisation - at.timers.factorisation;
        each.push(format!(
            "{time:.2} ({}, {made} in {took:.2})",
            report.newton_iterations
        ));
    }
    let size = format!(
        "| {} | {} | {} | {} | {setup:.2} | {} | {:.0} |",
        sim.state.grains.len(),
        sim.dofs().len,
        sim.state.contacts.contacts.len(),
        sim.factor_entries(),
        each.join(", "),
        peak_memory_mb()
    );
    let (t, t0) = (sim.stats.timers, before.timers);
    let factorisations =
        sim.stats.counters.numeric_factorisations - before.counters.numeric_factorisations;
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
