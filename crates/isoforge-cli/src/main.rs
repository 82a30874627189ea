//! The `isoforge` command line: `extract`, `info`, `check`, `demo`, `contour`, `convert`, `render`, `view`,
//! `voxelize`, `repair`.
//!
//! Exit codes: 0 success, 1 a requested check failed, 2 an error (printed as one line naming the
//! file and the problem). A closed stdout (broken pipe) counts as success.

mod args;
mod config;
mod outputs;
mod progress;
mod report;
mod run;
mod topo_repair;
mod view;
mod voxel;

use std::io::Write;
use std::process::ExitCode;

use clap::Parser;

use args::{Args, Command};
use run::Outcome;

fn main() -> ExitCode {
    // Like other command-line tools, stop quietly when the reader of stdout goes away
    // (`isoforge info x.nrrd | head`) instead of panicking on a broken pipe.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    isoforge_io::install_signal_cleanup();
    let args = match Args::try_parse() {
        Ok(a) => a,
        // A bare `isoforge`: the help, as an error.
        Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = e.print();
            return ExitCode::from(2);
        }
        Err(e) if e.use_stderr() => {
            eprintln!("isoforge: error: {}", args::usage_error_line(&e));
            return ExitCode::from(2);
        }
        // --help and --version.
        Err(e) => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
    };
    // `--threads` reaches the library as `Options::threads` (its own pool per extraction); it is
    // checked here so a bad value fails before any work.
    let threads = match config::threads(args.threads) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("isoforge: error: {e:#}");
            return ExitCode::from(2);
        }
    };
    // Only commands that mesh again: one-shot commands reuse nothing they free, and these
    // settings slowed the streamed file-to-file path (shoulder CT at one thread: 0.58 → 0.89 s).
    let again = match &args.command {
        Command::Extract(a) => a.repeat > 1,
        Command::View(_) => true,
        _ => false,
    };
    if again {
        isoforge_io::keep_freed_memory();
    }
    let result = match &args.command {
        Command::Extract(a) => config::ExtractConfig::from_args(a, threads).and_then(|c| run::extract(&c)),
        Command::Info(a) => config::InputConfig::from_args(&a.input_args()).and_then(|c| run::info(&c, a.json)),
        Command::Check(a) => config::CheckConfig::from_args(a).and_then(|c| run::check(&c)),
        Command::Demo(a) => config::DemoConfig::from_args(a, threads).and_then(|c| run::demo(&c)),
        Command::Contour(a) => config::ContourConfig::from_args(a).and_then(|c| run::contour(&c)),
        Command::View(a) => config::ViewConfig::from_args(a, threads).and_then(|c| run::view(&c)),
        Command::Render(a) => config::RenderConfig::from_args(a, threads).and_then(|c| run::render(&c)),
        Command::Convert(a) => config::ConvertConfig::from_args(a).and_then(|c| run::convert(&c)),
        Command::Voxelize(a) => config::VoxelizeConfig::from_args(a).and_then(|c| voxel::voxelize(&c)),
        Command::Repair(a) => config::RepairConfig::from_args(a).and_then(|c| voxel::repair(&c)),
        Command::Simplify(a) => config::SimplifyConfig::from_args(a, threads).and_then(|c| run::simplify(&c)),
        Command::TopoRepair(a) => config::TopoRepairConfig::from_args(a).and_then(|c| topo_repair::topo_repair(&c)),
    };
    let _ = std::io::stdout().flush();
    match result {
        Ok(Outcome::Success) => ExitCode::SUCCESS,
        Ok(Outcome::CheckFailed) => ExitCode::from(1),
        Err(e) => {
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            }) {
                return ExitCode::SUCCESS;
            }
            eprintln!("isoforge: error: {e:#}");
            ExitCode::from(2)
        }
    }
}
