//! `sdae-study`: convergence, stability and equipartition studies of the schemes on built-in or
//! user scenes (run by `cargo xtask study`; `sdae-study --help` lists the options).

/// Prints a line on standard output; a closed output (`| head`) ends the printing, never the
/// study.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// Prints a line on standard error; a closed stream ends the printing, never the study.
macro_rules! note {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

mod args;
mod expect_cli;
mod failure;
mod mlmc_cli;
mod runs;
mod shard;
mod simulate_cli;
mod stopping;

use clap::Parser;
use std::process::ExitCode;

use args::{Cli, Command};
use failure::Failure;
use stopping::{STOP, catch_signals};

/// Lane buffers start on cache lines: the lane ensembles run up to 20% faster
/// (docs/performance.md, "Where lane buffers start").
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        None => {
            catch_signals();
            runs::convergence(&cli.convergence, &STOP)
        }
        Some(Command::Convergence(args)) => {
            catch_signals();
            runs::convergence(&args, &STOP)
        }
        Some(Command::Stability(args)) => {
            catch_signals();
            runs::stability(&args, &STOP)
        }
        Some(Command::Equipartition(args)) => {
            catch_signals();
            runs::equipartition(&args, &STOP)
        }
        Some(Command::Weak(args)) => {
            catch_signals();
            runs::weak(&args, &STOP)
        }
        Some(Command::Merge(args)) => runs::merge(&args.dirs, &args.out.out),
        Some(Command::Trace(args)) => runs::trace(&args),
        Some(Command::Mlmc(args)) => {
            catch_signals();
            mlmc_cli::mlmc(&args, &STOP)
        }
        Some(Command::MlmcMerge(args)) => mlmc_cli::mlmc_merge(&args),
        Some(Command::Expect(args)) => {
            catch_signals();
            expect_cli::expect(&args, &STOP)
        }
        Some(Command::Simulate(args)) => {
            catch_signals();
            simulate_cli::simulate(&args, &STOP)
        }
        Some(Command::Compare(args)) => runs::compare(&args.first, &args.second),
        Some(Command::List) => {
            runs::list();
            Ok(())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Usage(message)) => {
            note!("error: {message}\n\nFor more information, try '--help'.");
            ExitCode::from(2)
        }
        Err(Failure::Failed(message)) => {
            note!("error: {message}");
            ExitCode::FAILURE
        }
        Err(Failure::Interrupted(message)) => {
            note!("{message}");
            ExitCode::from(130)
        }
        Err(Failure::Unsaved(message)) => {
            note!("{message}");
            ExitCode::from(131)
        }
    }
}
