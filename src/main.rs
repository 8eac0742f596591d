//! The `grainstat` command line: run a scene, prepare a sample, draw and summarise a result
//! file.

use clap::{Parser, Subcommand};
use grainstat::output::info;
use grainstat::output::plot::{default_dir, plot, plot_study};
use grainstat::run::{run_to_end, solver_settings, start, RunEnd, SceneInput};
use grainstat::sample::{write_csv, write_sample};
use grainstat::scene::{load_scene, load_solver, parse_solver};
use grainstat::solver::SolverConfig;
use grainstat::study::{compare, markdown, track, write_tables, StudyPlan, StudyRow, Track};
use grainstat::sweep;
use grainstat::{Error, InputError};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Exact quasi-static discrete element analysis of granular materials (2D).
#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene: solve every load increment for the equilibrium of all grains at once and
    /// write the state to HDF5.
    #[command(
        after_help = "Examples:\n  grainstat run examples/crystal-biaxial.toml\n  \
        grainstat run examples/sand-hertz.toml --solver solvers/relaxation.toml -o sand.h5\n  \
        grainstat run examples/crystal-biaxial.toml --resume results/crystal-biaxial.h5"
    )]
    Run {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Solver settings (TOML); default: the built-in settings of the minimisation
        /// (solvers/minimise.toml).
        #[arg(long)]
        solver: Option<PathBuf>,
        /// Result file; default: the scene's `output.file`, else results/NAME.h5.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Continue the run in this result file from its last complete increment.
        #[arg(long, value_name = "OUT.h5")]
        resume: Option<PathBuf>,
        /// Worker threads (results do not depend on it).
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// No progress bar and no per-increment log lines.
        #[arg(long)]
        quiet: bool,
        /// Do not draw the pictures and write the XDMF at the end.
        #[arg(long)]
        no_plot: bool,
    },
    /// Prepare a sample as the scene's `[sample]` section says: radii from the size
    /// distribution, grains sprinkled into the region and grown to the target isotropic
    /// stress with the friction lowered to f_gg', friction raised to the material's, brought to
    /// exact equilibrium, bonds made for a cemented material.
    #[command(
        after_help = "Examples:\n  grainstat generate examples/sample-sand.toml -o samples/sand.h5\n  \
        grainstat generate examples/sample-sand.toml -o samples/sand.h5 --csv samples/sand.csv"
    )]
    Generate {
        /// Scene file (TOML) with a `[sample]` section.
        scene: PathBuf,
        /// Sample file to write (HDF5).
        #[arg(short, long)]
        output: PathBuf,
        /// Also write the grains as `x,y,r` CSV (for other DEM codes).
        #[arg(long)]
        csv: Option<PathBuf>,
        /// Solver settings (TOML) for the final equilibrium.
        #[arg(long)]
        solver: Option<PathBuf>,
        /// Worker threads (the sample does not depend on it).
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// No progress bar and no summary.
        #[arg(long)]
        quiet: bool,
    },
    /// Draw a result file's pictures (SVG and PNG): stress-strain, volumetric strain,
    /// contacts per grain and bonds broken over the increments; forces, displacements and
    /// rotations of the grains and radar plots of the contacts at one increment. Also the
    /// curves as CSV, and the XDMF for ParaView beside the result file.
    #[command(
        after_help = "Examples:\n  grainstat plot results/crystal-biaxial.h5\n  \
        grainstat plot results/crystal-biaxial.h5 -o figures --increment 25"
    )]
    Plot {
        /// Result file (HDF5).
        file: PathBuf,
        /// Directory for the pictures and the CSV; default: NAME-plots beside NAME.h5.
        #[arg(short, long, value_name = "DIR")]
        output: Option<PathBuf>,
        /// The increment to draw the grains at; default: the last complete one.
        #[arg(long, value_name = "N")]
        increment: Option<usize>,
    },
    /// Speed against error: run the scene with the global solver over a range of tolerances
    /// and with the grain-by-grain relaxation over a range of sweeps per increment (n_i) and
    /// of tolerances, compare every increment with a reference run near machine precision,
    /// and write the table (study.csv, study-increments.csv, study.md) and the plots of error
    /// against CPU time, over the run and in the first increment (study.png,
    /// study-increment-1.png, and as SVG).
    #[command(
        after_help = "Example:\n  grainstat study examples/study-sand-biaxial.toml -o results/study-sand"
    )]
    Study {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Directory for the tables and the plots; default: results/study-NAME.
        #[arg(short, long, value_name = "DIR")]
        output: Option<PathBuf>,
        /// Settings of the reference run; default: solvers/reference.toml.
        #[arg(long, value_name = "SOLVER.toml")]
        reference: Option<PathBuf>,
        /// Settings of the global solver's runs; default: solvers/minimise.toml.
        #[arg(long, value_name = "SOLVER.toml", alias = "newton")]
        minimise: Option<PathBuf>,
        /// Settings of the relaxation runs; default: solvers/relaxation.toml.
        #[arg(long, value_name = "SOLVER.toml")]
        relaxation: Option<PathBuf>,
        /// Tolerances of the global solver's runs.
        #[arg(long, value_delimiter = ',', default_values_t = vec![1e-2, 1e-4, 1e-6, 1e-8, 1e-10])]
        tolerances: Vec<f64>,
        /// Sweeps per increment of the relaxation runs that make just that many.
        #[arg(long, value_delimiter = ',', default_values_t = vec![5, 20, 100, 500, 2000])]
        sweeps: Vec<usize>,
        /// Tolerances of the relaxation runs that sweep until they meet them.
        #[arg(long, value_delimiter = ',', default_values_t = vec![1e-3, 1e-5, 1e-7])]
        relaxation_tolerances: Vec<f64>,
        /// Sweeps per increment allowed to those.
        #[arg(long, default_value_t = 20000)]
        max_sweeps: usize,
        /// No progress lines.
        #[arg(long)]
        quiet: bool,
    },
    /// Run a test scene at several values of some of its keys (a biaxial test at several
    /// lateral pressures, a sample at several seeds) and collect the macro parameters of every
    /// run in one table (sweep.csv, sweep.md), with c' and phi' fitted to the peaks.
    #[command(
        after_help = "Example:\n  grainstat sweep examples/sweep-sand-lateral.toml -o results/sweep-sand"
    )]
    Sweep {
        /// Sweep file (TOML): `scene`, `keys`, `values`, and a `label` and `unit` for them.
        sweep: PathBuf,
        /// Directory for the runs, their pictures and the table; default: results/sweep-NAME.
        #[arg(short, long, value_name = "DIR")]
        output: Option<PathBuf>,
        /// Solver settings (TOML) of every run; default: the sweep file's `solver`, else the
        /// built-in settings of the minimisation.
        #[arg(long)]
        solver: Option<PathBuf>,
        /// Worker threads (results do not depend on it).
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// No progress lines.
        #[arg(long)]
        quiet: bool,
    },
    /// Round-off spread of a test: run the scene N times with its last stage's loads times
    /// 1 + k eps (k = 0 .. N-1), runs that differ by round-off alone, and report the failure
    /// load (a cylinder test's first breakout, else the peak deviator), iterations and CPU time
    /// of each with their medians and ranges (spread.md, spread.csv); with --halved, each also
    /// with the last stage in twice its increments, and the failure load's change on halving
    /// with its 95% bootstrap interval.
    #[command(
        after_help = "Examples:\n  grainstat spread examples/cylinder-test.toml --runs 24 --jobs 2\n  \
        grainstat spread examples/bend-test.toml --runs 20 --halved --figure wall:load"
    )]
    Spread {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Runs a step.
        #[arg(long, default_value_t = 12)]
        runs: usize,
        /// Relative change of the last stage's loads from one run to the next.
        #[arg(long, default_value_t = 1e-13)]
        eps: f64,
        /// Also run each with the last stage in twice its increments.
        #[arg(long)]
        halved: bool,
        /// Runs at a time, each on one thread (CPU times are each run's own).
        #[arg(long, default_value_t = 1)]
        jobs: usize,
        /// The failure load read from each run: breakout, deviator or wall:NAME (the largest
        /// stress on that wall or circle); default: breakout for a cylinder test, else
        /// deviator.
        #[arg(long)]
        figure: Option<String>,
        /// Solver settings (TOML) of every run; default: the built-in settings.
        #[arg(long)]
        solver: Option<PathBuf>,
        /// Directory for the runs and the table; default: results/spread-NAME.
        #[arg(short, long, value_name = "DIR")]
        output: Option<PathBuf>,
        /// No progress lines.
        #[arg(long)]
        quiet: bool,
    },
    /// Summarise a result file: scene, increments written, last stresses, timers, counters.
    #[command(after_help = "Example:\n  grainstat info results/crystal-biaxial.h5")]
    Info {
        /// Result file (HDF5).
        file: PathBuf,
    },
}

fn main() -> ExitCode {
    grainstat::give_back_large_blocks();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run {
            scene,
            solver,
            output,
            resume,
            threads,
            quiet,
            no_plot,
        } => on_threads(threads, || {
            run(&scene, solver.as_deref(), output, resume, quiet, !no_plot)
        }),
        Command::Generate {
            scene,
            output,
            csv,
            solver,
            threads,
            quiet,
        } => on_threads(threads, || {
            generate(&scene, &output, csv.as_deref(), solver.as_deref(), quiet)
        }),
        Command::Plot {
            file,
            output,
            increment,
        } => plot(&file, output.as_deref(), increment).map(|files| {
            for f in files {
                println!("{}", f.display());
            }
        }),
        Command::Study {
            scene,
            output,
            reference,
            minimise,
            relaxation,
            tolerances,
            sweeps,
            relaxation_tolerances,
            max_sweeps,
            quiet,
        } => on_threads(1, || {
            // One thread: CPU time is then the time of one core, comparable across strategies.
            study(
                &scene,
                output,
                [reference, minimise, relaxation],
                tolerances,
                sweeps,
                relaxation_tolerances,
                max_sweeps,
                quiet,
            )
        }),
        Command::Sweep {
            sweep,
            output,
            solver,
            threads,
            quiet,
        } => on_threads(threads, || {
            run_sweep_command(&sweep, output, solver.as_deref(), quiet)
        }),
        Command::Spread {
            scene,
            runs,
            eps,
            halved,
            jobs,
            figure,
            solver,
            output,
            quiet,
        } => figure
            .as_deref()
            .map(grainstat::spread::Figure::parse)
            .transpose()
            .map_err(Error::from)
            .and_then(|figure| {
                let plan = grainstat::spread::SpreadPlan {
                    runs,
                    eps,
                    halved,
                    jobs,
                    figure,
                };
                spread(&scene, &plan, solver.as_deref(), output, quiet)
            }),
        Command::Info { file } => info(&file).map(|text| print!("{text}")),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::from(match err {
                Error::Input(_) => 2,
                Error::Numeric(_) => 3,
                Error::Io { .. } => 4,
            })
        }
    }
}

/// Run `work` on one of a pool of `threads` threads (at least one), where its parallel
/// stages share their work. Started from inside the pool, a parallel stage begins at once on
/// the calling thread, which takes any share another thread has not picked up yet; started
/// from outside, it would wait for a sleeping thread to wake and then wake the caller again,
/// which on a loaded machine costs more than a stage of a few milliseconds gains.
fn on_threads(
    threads: usize,
    work: impl FnOnce() -> Result<(), Error> + Send,
) -> Result<(), Error> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .map_err(|e| Error::io("thread pool", e))?
        .install(work)
}

fn generate(
    scene_path: &Path,
    output: &Path,
    csv: Option<&Path>,
    solver_path: Option<&Path>,
    quiet: bool,
) -> Result<(), Error> {
    let input = SceneInput::load(scene_path)?;
    let (config, _) = solver_settings(solver_path)?;
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(1)
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:30} growing: step {pos}/{len} {elapsed} {msg}")
            .expect("valid template"),
    );
    let start = std::time::Instant::now();
    let prepared = input.prepare_sample(&config, |step, steps| {
        bar.set_length(steps as u64);
        bar.set_position(step as u64);
    });
    bar.finish_and_clear();
    let prepared = prepared?;
    write_sample(output, &prepared.sample)?;
    if let Some(csv) = csv {
        write_csv(csv, &prepared.sample.grains)?;
    }
    if !quiet {
        let m = &prepared.measurements;
        let walls: Vec<String> = m.wall_stress.iter().map(|s| format!("{s:.4e}")).collect();
        eprintln!(
            "{} grains in {:.1} s ({} growth steps, residual {:.1e}); {:.3} contacts per grain \
             (walls excluded); wall stresses [{}] Pa; macro xx {:.4e} yy {:.4e} Pa\nsample: {}",
            prepared.sample.grains.len(),
            start.elapsed().as_secs_f64(),
            prepared.growth.steps,
            prepared.residual,
            m.contacts_per_grain,
            walls.join(", "),
            m.macro_stress[0][0],
            m.macro_stress[1][1],
            output.display()
        );
    }
    Ok(())
}

fn run(
    scene_path: &Path,
    solver_path: Option<&Path>,
    output: Option<PathBuf>,
    resume: Option<PathBuf>,
    quiet: bool,
    pictures: bool,
) -> Result<(), Error> {
    let input = SceneInput::load(scene_path)?;
    let (config, solver_text) = solver_settings(solver_path)?;
    let (mut sim, mut file) = match &resume {
        Some(path) => input.resume_run(config, path)?,
        None => input.begin_run(config, &solver_text, output)?,
    };

    let total = sim.total_increments() as u64;
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(total)
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} increments {elapsed} (eta {eta}) {msg}")
            .expect("valid template"),
    );
    bar.set_position(sim.state.increment as u64);
    // Lines go above the bar on a terminal, and straight to standard error into a log file
    // (where the bar is not drawn and would swallow them).
    let say = |line: String| {
        if bar.is_hidden() {
            eprintln!("{line}");
        } else {
            bar.println(line);
        }
    };
    if !quiet {
        say(format!(
            "{}: {} grains, {} walls, {} unknowns, {} increments -> {}",
            sim.name,
            sim.state.grains.len(),
            sim.state.walls.len(),
            sim.dofs().len,
            total,
            file.path().display()
        ));
    }
    let result = run_to_end(
        &mut sim,
        Some(&mut file),
        input.scene.output.every,
        |sim, r| {
            bar.set_position(r.increment as u64);
            bar.set_message(format!(
                "residual {:.1e}, {} contacts",
                r.residual,
                sim.state.contacts.len()
            ));
            if !quiet {
                say(grainstat::run::log_line(sim, r));
            }
        },
    );
    bar.finish_and_clear();
    let path = file.path().to_path_buf();
    if !quiet {
        eprintln!("{}", grainstat::run::summary(&sim));
        eprintln!("results: {}", path.display());
    }
    // A failed run still has its last state on file. A stage loaded until failure ends at
    // the failure: said here, and a success.
    let result = result.map(|end| {
        if let RunEnd::Failed(failure) = end {
            eprintln!("{failure}");
        }
    });
    if !pictures {
        return result;
    }
    let plotted = plot(&path, None, None);
    match (result, plotted) {
        (Ok(()), Ok(files)) => {
            if !quiet {
                let parameters = default_dir(&path).join("parameters.md");
                if let Ok(table) = std::fs::read_to_string(&parameters) {
                    eprint!("{table}");
                }
                eprintln!("pictures: {}", default_dir(&path).display());
                if let Some(xmf) = files.last() {
                    eprintln!("ParaView: {}", xmf.display());
                }
            }
            Ok(())
        }
        (Ok(()), Err(err)) => Err(err),
        (Err(err), plotted) => {
            if let Err(e) = plotted {
                eprintln!("error: drawing the pictures: {e}");
            }
            Err(err)
        }
    }
}

/// Solver settings from a file, or from the preset shipped under `solvers/`.
fn preset(path: Option<&Path>, builtin: &str, name: &str) -> Result<SolverConfig, Error> {
    match path {
        Some(p) => Ok(load_solver(p)?.0),
        None => Ok(parse_solver(builtin, name)?),
    }
}

fn run_sweep_command(
    sweep_path: &Path,
    output: Option<PathBuf>,
    solver_path: Option<&Path>,
    quiet: bool,
) -> Result<(), Error> {
    let spec = sweep::load_sweep(sweep_path)?;
    let named = spec
        .solver
        .as_ref()
        .map(|s| sweep_path.parent().unwrap_or(Path::new(".")).join(s));
    let (config, solver_text) = solver_settings(solver_path.or(named.as_deref()))?;
    let name = sweep_path
        .file_stem()
        .map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned());
    let dir = output.unwrap_or_else(|| PathBuf::from(format!("results/sweep-{name}")));
    let runs = sweep::run_sweep(
        &spec,
        sweep_path,
        &config,
        &solver_text,
        &dir,
        |k, value| {
            if !quiet {
                eprintln!(
                    "run {}/{}: {} = {value}",
                    k + 1,
                    spec.values.len(),
                    spec.label
                );
            }
        },
    )?;
    let table = sweep::markdown(&spec, &runs);
    let (csv_path, md_path) = (dir.join("sweep.csv"), dir.join("sweep.md"));
    std::fs::write(&csv_path, sweep::csv(&spec, &runs))
        .map_err(|e| Error::io(csv_path.display(), e))?;
    std::fs::write(&md_path, &table).map_err(|e| Error::io(md_path.display(), e))?;
    if !quiet {
        eprint!("{table}");
    }
    println!("{}", csv_path.display());
    println!("{}", md_path.display());
    Ok(())
}

fn spread(
    scene_path: &Path,
    plan: &grainstat::spread::SpreadPlan,
    solver_path: Option<&Path>,
    output: Option<PathBuf>,
    quiet: bool,
) -> Result<(), Error> {
    use grainstat::spread;
    if plan.runs == 0 || !(plan.eps.is_finite() && plan.eps >= 0.0) {
        return Err(InputError::new(
            "--runs, --eps",
            "a spread needs one run or more and eps >= 0",
        )
        .into());
    }
    let (config, solver_text) = solver_settings(solver_path)?;
    let name = scene_path
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let dir = output.unwrap_or_else(|| PathBuf::from(format!("results/spread-{name}")));
    let runs = spread::run_spread(plan, scene_path, &config, &solver_text, &dir, |run| {
        if !quiet {
            let figure = run.figure.map_or("-".to_string(), |f| format!("{f:.6e}"));
            eprintln!(
                "k {} ({} increments): {} iterations, {:.2} s, {figure}; {}",
                run.k, run.increments, run.iterations, run.cpu, run.end
            );
        }
    })?;
    let table = spread::markdown(plan, scene_path, &runs);
    let (csv_path, md_path) = (dir.join("spread.csv"), dir.join("spread.md"));
    std::fs::write(&csv_path, spread::csv(&runs)).map_err(|e| Error::io(csv_path.display(), e))?;
    std::fs::write(&md_path, &table).map_err(|e| Error::io(md_path.display(), e))?;
    if !quiet {
        eprint!("{table}");
    }
    println!("{}", csv_path.display());
    println!("{}", md_path.display());
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn study(
    scene_path: &Path,
    output: Option<PathBuf>,
    [reference, minimise, relaxation]: [Option<PathBuf>; 3],
    tolerances: Vec<f64>,
    sweeps: Vec<usize>,
    relaxation_tolerances: Vec<f64>,
    max_sweeps: usize,
    quiet: bool,
) -> Result<(), Error> {
    let (scene, _) = load_scene(scene_path)?;
    let plan = StudyPlan {
        reference: preset(
            reference.as_deref(),
            include_str!("../solvers/reference.toml"),
            "solvers/reference.toml",
        )?,
        global: preset(
            minimise.as_deref(),
            include_str!("../solvers/minimise.toml"),
            "solvers/minimise.toml",
        )?,
        tolerances,
        relaxation: preset(
            relaxation.as_deref(),
            include_str!("../solvers/relaxation.toml"),
            "solvers/relaxation.toml",
        )?,
        sweeps,
        relaxation_tolerances,
        max_sweeps,
    };
    let dir = output.unwrap_or_else(|| PathBuf::from(format!("results/study-{}", scene.name)));
    let say = |text: String| {
        if !quiet {
            eprintln!("{text}");
        }
    };
    let total = scene.stages.iter().map(|s| s.increments).sum::<usize>();
    let run = |label: &str, config: SolverConfig| -> Result<Track, Error> {
        let mut sim = start(&scene, scene_path, config)?;
        let track = track(&mut sim, |k| {
            if !quiet {
                eprint!("\r{label}: increment {k}/{total}   ");
            }
        });
        say(format!(
            "\r{label}: {:.2} s CPU, {} iterations, {} cuts{}",
            track.cpu,
            track.iterations,
            track.cuts,
            track
                .failure
                .as_ref()
                .map(|f| format!(", stopped: {f}"))
                .unwrap_or_default()
        ));
        Ok(track)
    };
    // Without a finished reference there is nothing to measure against: its failure is the
    // study's (another reference can be given with --reference).
    let reference = run("reference", plan.reference.clone())?;
    if let Some(failure) = reference.failure.clone() {
        return Err(failure.into());
    }
    let mut rows = Vec::new();
    for trial in plan.trials() {
        let track = run(
            &format!("{} {}", trial.solver, trial.setting),
            trial.config.clone(),
        )?;
        let errors = compare(&track, &reference);
        rows.push(StudyRow {
            trial,
            track,
            errors,
        });
    }
    let mut files = write_tables(&dir, &scene.name, &reference, &rows)?;
    files.extend(plot_study(&dir, &scene.name, &rows)?);
    if !quiet {
        eprint!("{}", markdown(&scene.name, &reference, &rows));
    }
    for f in files {
        println!("{}", f.display());
    }
    Ok(())
}
