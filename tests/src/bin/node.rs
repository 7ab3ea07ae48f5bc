//! `seam node` as a binary of this crate, so the pod tests can start real pods
//! (`env!("CARGO_BIN_EXE_seam-test-node")`) without depending on where cargo put `seam`.

use std::process::ExitCode;

use clap::Parser;
use seam_bench::node::{self, NodeArgs};

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    args: NodeArgs,
}

fn main() -> ExitCode {
    let args = Cli::parse().args;
    let result = node::stop_flag()
        .and_then(|stop| node::run_node(&args, &stop, &mut std::io::stdout().lock()));
    match result {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("seam-test-node: {e}");
            ExitCode::FAILURE
        }
    }
}
