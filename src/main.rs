//! The `hydrofrac` command line.

use anyhow::Result;
use clap::{Parser, Subcommand};
use hydrofrac::driver::{RunOptions, run_file};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize};

#[derive(Parser)]
#[command(
    name = "hydrofrac",
    version,
    about = "Hydraulic fracturing in hard rock: explicit FEM rock mass and fracture-network flow (SI units, tension positive)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scenario (RON) and write its outputs.
    Run {
        /// Scenario file, e.g. scenarios/insitu_stress.ron
        scenario: PathBuf,
        /// Output folder [default: out/<scenario name>]. The run lists every file it writes
        /// in the folder's hydrofrac-manifest.txt; a run into a folder with a manifest
        /// removes the files listed there (and nothing else) before it writes
        #[arg(long)]
        out: Option<PathBuf>,
        /// Switch a system off (repeatable); see `hydrofrac systems`
        #[arg(long = "disable", value_name = "NAME")]
        disable: Vec<String>,
        /// Override a scenario value, e.g. --set material.young=3e10 (repeatable)
        #[arg(long = "set", value_name = "PATH=VALUE")]
        set: Vec<String>,
        /// Write a Chrome/Perfetto trace of the systems to FILE
        #[arg(long, value_name = "FILE")]
        trace: Option<PathBuf>,
        /// No progress bar and no timing table
        #[arg(long)]
        quiet: bool,
        /// Write into a non-empty folder that has no hydrofrac-manifest.txt (refused without
        /// it). Nothing in the folder is deleted; files with the names the run writes are
        /// overwritten and listed in the manifest as the run's (the next run removes them)
        #[arg(long)]
        force: bool,
        /// Refuse a scenario whose mesh and network would need more memory than SIZE (bytes,
        /// or with KiB, MiB, GiB, TiB: 8GiB), estimated before anything is allocated
        /// [default: the machine's memory, MemTotal of /proc/meminfo, else 16GiB]
        #[arg(long, value_name = "SIZE", value_parser = hydrofrac::resources::parse_size)]
        max_memory: Option<u64>,
        /// Refuse a run whose outputs (frames, time series, figures) would take more than
        /// SIZE on disk (bytes, or with KiB, MiB, GiB, TiB), estimated after setup and before
        /// anything is written [default: the free space of the output folder's disk]
        #[arg(long, value_name = "SIZE", value_parser = hydrofrac::resources::parse_size)]
        max_disk: Option<u64>,
        /// Continue from a checkpoint (`output.checkpoint_every` writes checkpoint.ckpt in
        /// the output folder): bit for bit the run that wrote it. Refused unless written by
        /// this hydrofrac for the same scenario, --set overrides and --disable list
        #[arg(long, value_name = "FILE")]
        restart: Option<PathBuf>,
    },
    /// Run verification cases at several resolutions: error and wall time (CSV + PNG).
    Verify {
        /// Cases to run [default: all]
        cases: Vec<String>,
        /// Output folder (same rules as `run --out`: a manifest lists what it wrote)
        #[arg(long, default_value = "out/verify")]
        out: PathBuf,
        /// Fewer and smaller resolutions (seconds instead of minutes)
        #[arg(long)]
        quick: bool,
        /// Write into a non-empty folder that has no hydrofrac-manifest.txt (refused without
        /// it). Nothing in the folder is deleted; files with the names the run writes are
        /// overwritten and listed in the manifest as the run's (the next run removes them)
        #[arg(long)]
        force: bool,
    },
    /// Stimulation -> doublet (production between two wells) -> upscaling -> heat extraction,
    /// before and after, in one run (a pipeline file, e.g. scenarios/example1_reservoir.ron).
    Pipeline {
        /// Pipeline file (RON)
        file: PathBuf,
        /// Output folder [default: out/<pipeline name>] (same rules as `run --out`); the
        /// stimulation writes into its `stimulation/` folder
        #[arg(long)]
        out: Option<PathBuf>,
        /// No progress bar and no stage table
        #[arg(long)]
        quiet: bool,
        /// Write into a non-empty folder that has no hydrofrac-manifest.txt (see `run --force`)
        #[arg(long)]
        force: bool,
    },
    /// List the systems of a step in order.
    Systems,
    /// Ensembles: plan a sweep of a scenario over varied values, run its members (here or as
    /// a Slurm job array) and collect their results (docs/sweep.md).
    Sweep {
        #[command(subcommand)]
        command: SweepCommand,
    },
}

#[derive(Subcommand)]
enum SweepCommand {
    /// Resolve and validate every member of a sweep file and write them into DIR (nothing
    /// runs): DIR/plan.json and DIR/members/NNNN/scenario.ron.
    Plan {
        /// Sweep file (RON), e.g. scenarios/sweep_example.ron
        file: PathBuf,
        /// The sweep folder (new, empty, or planned before; a folder of other files is
        /// refused)
        #[arg(long)]
        out: PathBuf,
    },
    /// Run the members of a planned sweep on this machine, each as its own process; finished
    /// members are skipped, an interrupted one continues from its checkpoint.
    Run {
        /// The sweep folder
        dir: PathBuf,
        /// Members run at a time [default: the number of CPUs]
        #[arg(long)]
        jobs: Option<usize>,
        /// Threads of each member [default: the CPUs / --jobs, at least 1; RAYON_NUM_THREADS
        /// when set]. The results are the same bits for any count.
        #[arg(long)]
        threads: Option<usize>,
        /// Run only these members, in this order: ids and ranges, e.g. `60-95`, or `95-60`
        /// for the last first, or `0,5,9-12` (to split a study between machines)
        #[arg(long)]
        members: Option<String>,
        /// Run the members that failed before again (else they are skipped)
        #[arg(long)]
        retry_failed: bool,
        /// No progress bar
        #[arg(long)]
        quiet: bool,
    },
    /// Run one member (what `sweep run` and the Slurm array tasks run).
    Member {
        /// The sweep folder
        dir: PathBuf,
        /// Member id (0 to members - 1)
        id: usize,
        /// No message unless it fails
        #[arg(long)]
        quiet: bool,
    },
    /// Write a Slurm job array (DIR/slurm/sweep.sbatch) running every member, and with
    /// --submit submit it.
    Slurm {
        /// The sweep folder
        dir: PathBuf,
        /// #SBATCH --partition
        #[arg(long)]
        partition: Option<String>,
        /// #SBATCH --time (e.g. 00:30:00)
        #[arg(long)]
        time: Option<String>,
        /// At most M members at once (--array=0-(N-1)%M)
        #[arg(long, value_name = "M")]
        max_parallel: Option<usize>,
        /// Members per array: Slurm's MaxArraySize less one; a larger sweep gets one script
        /// per block
        #[arg(long, default_value_t = 1000)]
        max_array_size: usize,
        /// The hydrofrac executable the tasks run [default: this one]
        #[arg(long)]
        exe: Option<PathBuf>,
        /// Submit the script(s) with sbatch
        #[arg(long)]
        submit: bool,
        /// With --submit: sbatch --wait (return when every member has run)
        #[arg(long)]
        wait: bool,
    },
    /// One table (DIR/collect/table.csv and .json) of every member's inputs and quantities of
    /// interest, failed members with their errors, and figures.
    Collect {
        /// The sweep folder
        dir: PathBuf,
        /// Leave out the figures
        #[arg(long)]
        no_figures: bool,
    },
}

fn main() -> ExitCode {
    match real_main() {
        Ok(code) => code,
        Err(e) => {
            // Never panics: a closed stderr loses the message, the exit status stays.
            let _ = writeln!(std::io::stderr(), "error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes in one line, `a: b: c`, leaving out a cause whose text the line
/// already holds (a message that quotes its source, as most here do, is not repeated).
fn one_line(e: &anyhow::Error) -> String {
    let mut line = e.to_string();
    for cause in e.chain().skip(1) {
        let m = cause.to_string();
        if !line.contains(&m) {
            line += ": ";
            line += &m;
        }
    }
    line
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Exit status of a run stopped by signal `sig`: 128 + the signal number, as a shell reports
/// a process killed by it (130 for SIGINT, 143 for SIGTERM).
fn signal_exit(sig: usize) -> ExitCode {
    ExitCode::from(u8::try_from(128 + sig).unwrap_or(1))
}

/// SIGINT and SIGTERM set the returned flag to the signal's number; the run checks it between
/// steps and ends as `interrupted` with its outputs finished. A second signal while the run is
/// finishing ends the process at once with status 128 + the signal number (its outputs may
/// then be incomplete: a frame or figure being written stays as a `*.tmp.*` file, which the
/// next run into the folder removes).
fn install_stop_handlers() -> Result<hydrofrac::sim::StopFlag> {
    Ok(install_stop_handlers_armed(false)?.0)
}

/// [`install_stop_handlers`], with the flag that makes the next signal end the process at
/// once: `exit_at_once` true until the run clears it (`RunOptions::exit_until_output`).
fn install_stop_handlers_armed(
    exit_at_once: bool,
) -> Result<(hydrofrac::sim::StopFlag, Arc<AtomicBool>)> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let stop = Arc::new(AtomicUsize::new(0));
    let armed = Arc::new(AtomicBool::new(exit_at_once));
    for sig in [SIGINT, SIGTERM] {
        // The order matters: the shutdown checks `armed` before the first signal sets it.
        signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, armed.clone())?;
        signal_hook::flag::register(sig, armed.clone())?;
        signal_hook::flag::register_usize(sig, stop.clone(), sig as usize)?;
    }
    Ok((stop, armed))
}

/// The one-line result, the timing table and the folder, on stdout.
fn print_report(report: &hydrofrac::driver::RunReport) -> std::io::Result<()> {
    let s = &report.summary;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: {} after {} steps, t = {:.6e} s, {} elements, wall {:.2} s ({})",
        s["scenario"].as_str().unwrap_or(""),
        s["status"].as_str().unwrap_or(""),
        s["steps"],
        s["time"].as_f64().unwrap_or(0.0),
        s["elements"],
        s["wall_s"].as_f64().unwrap_or(0.0),
        s["finish"].as_str().unwrap_or(""),
    )?;
    if s["finish"] == "max_steps" {
        let _ = writeln!(
            std::io::stderr(),
            "warning: stopped at time.max_steps before the end condition was met"
        );
    }
    // The summary's warnings (fractures that zigzag or reach outside the domain, tables not
    // written, production states that did not converge), also on stderr.
    for w in s["warnings"].as_array().into_iter().flatten() {
        if let Some(w) = w.as_str() {
            let _ = writeln!(std::io::stderr(), "warning: {w}");
        }
    }
    writeln!(out, "{}", report.timing_table)?;
    writeln!(out, "outputs in {}", report.out.display())
}

fn real_main() -> Result<ExitCode> {
    match Cli::parse().command {
        Command::Run {
            scenario,
            out,
            disable,
            set,
            trace,
            quiet,
            force,
            max_memory,
            max_disk,
            restart,
        } => {
            // A signal during setup (nothing written yet) ends the process at once.
            let (stop, armed) = install_stop_handlers_armed(true)?;
            let opts = RunOptions {
                out,
                disable,
                set,
                trace,
                quiet,
                force,
                stop: Some(stop),
                max_memory,
                max_disk,
                restart,
                exit_until_output: Some(armed),
            };
            run_command(&scenario, &opts)
        }
        Command::Verify {
            cases,
            out,
            quick,
            force,
        } => verify_command(&cases, &out, quick, force),
        Command::Pipeline {
            file,
            out,
            quiet,
            force,
        } => {
            // A signal while the stimulation scene is read and checked ends it at once.
            let (stop, armed) = install_stop_handlers_armed(true)?;
            let opts = hydrofrac::pipeline::PipelineOptions {
                out,
                quiet,
                force,
                stop: Some(stop),
                exit_until_output: Some(armed),
            };
            pipeline_command(&file, &opts)
        }
        Command::Systems => systems_command(),
        Command::Sweep { command } => sweep_command(command),
    }
}

/// `hydrofrac sweep ...`.
fn sweep_command(command: SweepCommand) -> Result<ExitCode> {
    use hydrofrac::sweep;
    let mut out = std::io::stdout().lock();
    match command {
        SweepCommand::Plan { file, out: dir } => {
            let plan = sweep::plan_sweep(&file, &dir)?;
            let _ = writeln!(
                out,
                "planned {} members of {} in {}",
                plan.members.len(),
                file.display(),
                dir.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        SweepCommand::Run {
            dir,
            jobs,
            threads,
            members,
            retry_failed,
            quiet,
        } => sweep_run_command(&dir, jobs, threads, members, retry_failed, quiet),
        SweepCommand::Member { dir, id, quiet } => {
            // A signal during the member's setup ends it at once (as `run` does); its
            // status stays `running`, which a later `sweep run` runs again.
            let (stop, armed) = install_stop_handlers_armed(true)?;
            match sweep::run_member(&dir, id, Some(stop), Some(armed))? {
                sweep::MemberOutcome::Ok => {
                    if !quiet {
                        let _ = writeln!(out, "member {id}: ok");
                    }
                    Ok(ExitCode::SUCCESS)
                }
                sweep::MemberOutcome::AlreadyDone => {
                    if !quiet {
                        let _ = writeln!(out, "member {id}: finished before");
                    }
                    Ok(ExitCode::SUCCESS)
                }
                sweep::MemberOutcome::Failed(e) => anyhow::bail!("member {id}: {e}"),
                sweep::MemberOutcome::Interrupted(sig) => Ok(signal_exit(sig)),
            }
        }
        SweepCommand::Slurm {
            dir,
            partition,
            time,
            max_parallel,
            max_array_size,
            exe,
            submit,
            wait,
        } => {
            let exe = match exe {
                Some(e) => e,
                None => std::env::current_exe()?,
            };
            let opts = sweep::SlurmOptions {
                partition,
                time,
                max_parallel,
                max_array_size,
                exe,
                submit,
                wait,
            };
            let r = sweep::write_slurm(&dir, &opts)?;
            for s in &r.scripts {
                let _ = writeln!(out, "wrote {}", s.display());
            }
            for s in &r.submitted {
                let _ = writeln!(out, "{s}");
            }
            Ok(ExitCode::SUCCESS)
        }
        SweepCommand::Collect { dir, no_figures } => {
            let opts = sweep::CollectOptions {
                figures: !no_figures,
            };
            let r = sweep::collect(&dir, &opts)?;
            for w in &r.warnings {
                let _ = writeln!(std::io::stderr(), "warning: {w}");
            }
            let _ = writeln!(
                out,
                "{} members: {} ok, {} failed, {} not run; table in {}",
                r.total,
                r.ok,
                r.failed.len(),
                r.not_run.len(),
                r.out.join("table.csv").display()
            );
            for (id, e) in &r.failed {
                let _ = writeln!(out, "member {id} failed: {e}");
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// `hydrofrac run`: the run, its reason on stderr when a signal stopped it, the report on
/// stdout unless `--quiet`; exit 128 + the signal number when a signal stopped it.
fn run_command(scenario: &std::path::Path, opts: &RunOptions) -> Result<ExitCode> {
    let report = run_file(scenario, opts)?;
    let code = report.interrupted_by.map_or(ExitCode::SUCCESS, signal_exit);
    if let Some(reason) = report.summary["reason"].as_str() {
        let _ = writeln!(
            std::io::stderr(),
            "{reason}: outputs finished in {}",
            report.out.display()
        );
    }
    if !opts.quiet
        && let Err(e) = print_report(&report)
    {
        // A closed stdout: the run is done and its outputs are written.
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            return Err(e.into());
        }
    }
    Ok(code)
}

/// `hydrofrac verify`: the cases into `out` (what they wrote listed in its manifest); failure
/// when a case failed, 128 + the signal number when a signal stopped them.
fn verify_command(
    cases: &[String],
    out: &std::path::Path,
    quick: bool,
    force: bool,
) -> Result<ExitCode> {
    let known = hydrofrac::verify::cases();
    if cases.iter().any(|n| !known.iter().any(|c| c.name == n)) {
        // `run_cases` names the unknown case (and the valid ones) before it writes
        // anything: the folder is not touched.
        hydrofrac::verify::run_cases(cases, out, quick)?;
    }
    // The cases write their files by name; what is new or changed afterwards is
    // listed in the manifest as this run's.
    let folder = hydrofrac::output::folder::Folder::prepare(out, force)?;
    let before = folder.snapshot();
    // SIGINT/SIGTERM: the case in progress finishes and is written, the rest is not
    // run (a second signal ends the process at once).
    let stop = install_stop_handlers()?;
    let result = hydrofrac::verify::run_cases_until(cases, out, quick, Some(&stop));
    folder.adopt_changed(&before)?;
    // A closed stdout stops the cases at their next line: not a quiet success here.
    let verdict = result.map_err(|e| {
        if is_broken_pipe(&e) {
            anyhow::anyhow!("stdout was closed: the verification stopped before it finished")
        } else {
            e
        }
    })?;
    if let Some(sig) = verdict.interrupted_by {
        let _ = writeln!(
            std::io::stderr(),
            "interrupted by {} after {} of {} cases: their CSV and PNG are in {}",
            hydrofrac::driver::signal_name(sig),
            verdict.finished.len(),
            verdict.total,
            out.display()
        );
        return Ok(signal_exit(sig));
    }
    Ok(if verdict.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// `hydrofrac pipeline`: the pipeline, its tables on stdout unless `--quiet`; 128 + the
/// signal number when a signal stopped the stimulation.
fn pipeline_command(
    file: &std::path::Path,
    opts: &hydrofrac::pipeline::PipelineOptions,
) -> Result<ExitCode> {
    let report = match hydrofrac::pipeline::run_pipeline(file, opts) {
        Err(e @ hydrofrac::pipeline::PipelineError::Interrupted { signal, .. }) => {
            let _ = writeln!(std::io::stderr(), "{e}");
            return Ok(signal_exit(signal));
        }
        r => r?,
    };
    if !opts.quiet {
        let mut o = std::io::stdout().lock();
        let text = hydrofrac::pipeline::report_text(&report);
        if let Err(e) = write!(o, "{text}")
            && e.kind() != std::io::ErrorKind::BrokenPipe
        {
            return Err(e.into());
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// `hydrofrac systems`: the systems of a step in order, with their docs.
fn systems_command() -> Result<ExitCode> {
    let mut out = std::io::stdout().lock();
    for s in hydrofrac::systems::SystemId::ORDER {
        // A closed stdout (`hydrofrac systems | head -1`): the rest has no reader; a
        // quiet exit, not a panic.
        match writeln!(out, "{:<16} {}", s.name(), s.doc()) {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => break,
            r => r?,
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// `hydrofrac sweep run`: the local runner, its counts on stdout; failure when a member
/// failed, 128 + the signal number when a signal stopped it.
fn sweep_run_command(
    dir: &std::path::Path,
    jobs: Option<usize>,
    threads: Option<usize>,
    members: Option<String>,
    retry_failed: bool,
    quiet: bool,
) -> Result<ExitCode> {
    use hydrofrac::sweep;
    let mut out = std::io::stdout().lock();
    let cpus = std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get);
    let jobs = jobs.unwrap_or(cpus);
    if jobs == 0 {
        anyhow::bail!("--jobs 0: at least 1");
    }
    if threads == Some(0) {
        anyhow::bail!("--threads 0: at least 1");
    }
    // Each member is a process with its own thread pool: without a share, `--jobs N` runs
    // N pools of every CPU each. The user's RAYON_NUM_THREADS, when set, is theirs.
    let threads = threads.or_else(|| {
        std::env::var_os("RAYON_NUM_THREADS")
            .is_none()
            .then(|| (cpus / jobs).max(1))
    });
    let opts = sweep::LocalOptions {
        jobs,
        retry_failed,
        quiet,
        stop: Some(install_stop_handlers()?),
        exe: std::env::current_exe()?,
        members,
        threads,
    };
    let s = sweep::run_local(dir, &opts)?;
    let _ = writeln!(
        out,
        "{} members: {} run now, {} finished before, {} failed now, {} failed before \
         (not retried), {} not run{}",
        s.total,
        s.ok,
        s.skipped,
        s.failed.len(),
        s.skipped_failed,
        s.not_run,
        if s.not_selected > 0 {
            format!(" ({} not selected by --members)", s.not_selected)
        } else {
            String::new()
        }
    );
    if let Some(sig) = s.interrupted_by {
        let _ = writeln!(
            std::io::stderr(),
            "interrupted by {}: `hydrofrac sweep run {}` continues",
            hydrofrac::driver::signal_name(sig),
            dir.display()
        );
        return Ok(signal_exit(sig));
    }
    if !s.failed.is_empty() {
        let ids: Vec<String> = s.failed.iter().map(|f| f.0.to_string()).collect();
        anyhow::bail!(
            "{} of {} members failed (members {}; their errors are in their status.json \
             and in `hydrofrac sweep collect {}`)",
            s.failed.len(),
            s.total,
            ids.join(", "),
            dir.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}
