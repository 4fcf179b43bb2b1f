//! The `hydrofrac` command line.

use anyhow::Result;
use clap::{Parser, Subcommand};
use hydrofrac::driver::{RunOptions, run_file};
use std::path::PathBuf;
use std::process::ExitCode;

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
    /// List the systems of a step in order.
    Systems,
}

fn main() -> ExitCode {
    match real_main() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn real_main() -> Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        Command::Run {
            scenario,
            out,
            disable,
            set,
            trace,
            quiet,
            force,
        } => {
            let opts = RunOptions {
                out,
                disable,
                set,
                trace,
                quiet,
                force,
            };
            let report = run_file(&scenario, &opts)?;
            if !quiet {
                let s = &report.summary;
                println!(
                    "{}: {} after {} steps, t = {:.6e} s, {} elements, wall {:.2} s ({})",
                    s["scenario"].as_str().unwrap_or(""),
                    s["status"].as_str().unwrap_or(""),
                    s["steps"],
                    s["time"].as_f64().unwrap_or(0.0),
                    s["elements"],
                    s["wall_s"].as_f64().unwrap_or(0.0),
                    s["finish"].as_str().unwrap_or(""),
                );
                if s["finish"] == "max_steps" {
                    eprintln!(
                        "warning: stopped at time.max_steps before the end condition was met"
                    );
                }
                println!("{}", report.timing_table);
                println!("outputs in {}", report.out.display());
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Verify {
            cases,
            out,
            quick,
            force,
        } => {
            let known = hydrofrac::verify::cases();
            if cases.iter().any(|n| !known.iter().any(|c| c.name == n)) {
                // `run_cases` names the unknown case (and the valid ones) before it writes
                // anything: the folder is not touched.
                hydrofrac::verify::run_cases(&cases, &out, quick)?;
            }
            // The cases write their files by name; what is new or changed afterwards is
            // listed in the manifest as this run's.
            let folder = hydrofrac::output::folder::Folder::prepare(&out, force)?;
            let before = folder.snapshot();
            let result = hydrofrac::verify::run_cases(&cases, &out, quick);
            folder.adopt_changed(&before)?;
            let ok = result?;
            Ok(if ok {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            })
        }
        Command::Systems => {
            for s in hydrofrac::systems::SystemId::ORDER {
                println!("{:<16} {}", s.name(), s.doc());
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}
