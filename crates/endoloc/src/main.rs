//! `endoloc`: image-based colonoscope localization from the command line.
//!
//! The binary is a thin shell: each subcommand lives in `cmd/<name>.rs`, turns its raw
//! arguments into a validated library config, runs the library, and reports.

mod cmd;
mod ui;

use clap::{Parser, Subcommand};

/// Tell where a colonoscope is inside the colon from the images it sees.
///
/// Typical flow: `simulate` (or import) a dataset with known poses, inspect it with
/// `dataset info`/`dataset check`, then train, map, localize and evaluate.
#[derive(Debug, Parser)]
#[command(name = "endoloc", version, about, long_about = None, propagate_version = true)]
struct Cli {
    /// More log output (-v info, -vv debug); errors and warnings are always shown.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,

    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    Simulate(cmd::simulate::Args),
    Features(cmd::features::Args),
    Dataset(cmd::dataset::Args),
    Eval(cmd::eval::Args),
    Import(cmd::import::Args),
    Pretrain(cmd::pretrain::Args),
    Train(cmd::train::Args),
    Classify(cmd::classify::Args),
    Map(cmd::localize::MapArgs),
    Localize(cmd::localize::LocalizeArgs),
    Demo(cmd::demo::Args),
    Run(cmd::run::Args),
    Experiment(cmd::experiment::Args),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    ui::init_logging(cli.verbose);
    let result = match cli.command {
        Command::Simulate(args) => cmd::simulate::run(args),
        Command::Features(args) => cmd::features::run(args),
        Command::Dataset(args) => cmd::dataset::run(args),
        Command::Eval(args) => cmd::eval::run(args),
        Command::Import(args) => cmd::import::run(args),
        Command::Pretrain(args) => cmd::pretrain::run(args),
        Command::Train(args) => cmd::train::run(args),
        Command::Classify(args) => cmd::classify::run(args),
        Command::Map(args) => cmd::localize::run_map(args),
        Command::Localize(args) => cmd::localize::run_localize(args),
        Command::Demo(args) => cmd::demo::run(args),
        Command::Run(args) => cmd::run::run(args),
        Command::Experiment(args) => cmd::experiment::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
