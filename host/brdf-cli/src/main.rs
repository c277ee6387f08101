//! `brdf`: evaluate the six-parameter BRDF model family from the command line.

/// `eprintln!` that never fails the command: a write to standard error that fails (a pipe
/// whose reader has gone) is dropped, and the command goes on. `eprintln!` panics there
/// instead (exit 101, and whatever standard output had still to print lost). Every line this
/// binary writes to standard error goes through here (`clippy.toml` refuses `eprintln!`).
macro_rules! eprintln_lossy {
    ($($arg:tt)*) => {{
        use ::std::io::Write as _;
        let _ = ::std::writeln!(::std::io::stderr(), $($arg)*);
    }};
}

mod angles;
mod bench;
mod bench_fit;
mod check;
mod common;
mod device;
mod eval;
mod fit;
mod flash;
mod formats;
mod import;
mod pack;
mod params;
mod plot;
mod progress;
mod query;
mod report;
mod scene;
mod select;
mod synth;

use clap::{Parser, Subcommand};

/// BRDF toolkit: the six-parameter model of Yang, Wu and Cao (2012) and its family.
#[derive(Debug, Parser)]
#[command(name = "brdf", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Chart cost against accuracy: evaluation variants, fitting methods.
    Bench(bench::BenchCmd),
    /// Cross-check a device (QEMU, serial or probe) against the host's f64 model.
    Check(check::CheckCmd),
    /// Evaluate a model over a CSV of angles (theta_i, theta_r, phi in degrees).
    Eval(eval::EvalCmd),
    /// Convert a measurement file in another convention to the canonical CSV.
    Import(import::ImportCmd),
    /// Fit a model to measured data (one or many datasets).
    Fit(fit::FitCmd),
    /// Write a parameter blob into a board's inactive flash slot through a debug probe.
    Flash(flash::FlashCmd),
    /// Build a parameter blob for the firmware from fit results.
    Pack(pack::PackCmd),
    /// Fit models to a dataset and plot them (in-plane curves, hemisphere map, residuals).
    Plot(plot::PlotCmd),
    /// Ask a device for BRDF values.
    Query(query::QueryCmd),
    /// Regenerate the model-comparison report over the shared measured datasets.
    Report(report::ReportCmd),
    /// Laser radar cross-section of a meshed target over a sensor sweep, and the BRDF
    /// queries it makes.
    Scene(scene::SceneCmd),
    /// Fit the model ladder and name the simplest model within an error budget.
    Select(select::SelectCmd),
    /// Write a synthetic dataset from known parameters.
    Synth(synth::SynthCmd),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Bench(cmd) => cmd.run(),
        Command::Check(cmd) => cmd.run(),
        Command::Eval(cmd) => cmd.run(),
        Command::Fit(cmd) => cmd.run(),
        Command::Flash(cmd) => cmd.run(),
        Command::Import(cmd) => cmd.run(),
        Command::Pack(cmd) => cmd.run(),
        Command::Plot(cmd) => cmd.run(),
        Command::Query(cmd) => cmd.run(),
        Command::Report(cmd) => cmd.run(),
        Command::Scene(cmd) => cmd.run(),
        Command::Select(cmd) => cmd.run(),
        Command::Synth(cmd) => cmd.run(),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        // A closed pipe (`brdf eval ... | head`) is the reader's choice, not an error.
        Err(err) if is_broken_pipe(&err) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln_lossy!("error: {}", message(&err));
            std::process::ExitCode::FAILURE
        }
    }
}

/// The error and its causes, joined by `: `, each cause only once: a cause whose text an
/// outer message already contains (an OS error quoted by its context, say) is not repeated.
fn message(err: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in err.chain() {
        let c = cause.to_string();
        if text.contains(&c) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&c);
    }
    text
}

fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|e| {
        let io = e.downcast_ref::<std::io::Error>().or_else(|| {
            e.downcast_ref::<csv::Error>().and_then(|c| match c.kind() {
                csv::ErrorKind::Io(io) => Some(io),
                _ => None,
            })
        });
        io.is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
