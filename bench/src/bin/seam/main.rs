//! `seam` — run and measure seam. See `seam --help`.
//!
//! Layout: `cli` holds the commands and their help, `cmd/` one module per command with its
//! flags and what it does; `main` runs the one asked for and turns its error into the exit
//! status.

mod cli;
mod cmd;

use std::process::ExitCode;

use clap::Parser;
use seam_bench::error::BenchResult;

use cli::{Cli, Command};

fn main() -> ExitCode {
    let cli = Cli::parse();
    seam_bench::console::init_logs();
    match run(&cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("seam: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The command asked for.
fn run(command: &Command) -> BenchResult<()> {
    match command {
        Command::Run(args) => cmd::run::main(args),
        Command::Compare(args) => cmd::compare::main(args),
        Command::Sweep(args) => cmd::sweep::main(args),
        Command::Network(args) => cmd::network::main(args),
        Command::Chaos(args) => cmd::chaos::main(args),
        Command::Capacity(args) => cmd::capacity::main(args),
        Command::Inspect(args) => cmd::inspect::main(args),
        Command::Node(args) => cmd::node::main(args),
        Command::Bridge(args) => cmd::bridge::main(args),
        Command::Ping(args) => cmd::ping::main(args),
        Command::Keys(args) => cmd::keys::main(args),
        Command::Throughput(args) => cmd::throughput::main(args),
        Command::Ops(args) => cmd::ops::main(args),
        Command::Scene(args) => cmd::scene::main(args),
        Command::OpsOwner(args) => cmd::ops::owner(args),
        Command::PingPeer(args) => cmd::ping::peer(args),
        Command::PingFloorPeer(args) => cmd::ping::floor_peer(args),
    }
}
