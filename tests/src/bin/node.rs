//! `seam node` (and `seam bridge`, when the first argument is `bridge`) as a binary of this
//! crate, so the pod tests can start real pods and bridges (`env!("CARGO_BIN_EXE_seam-test-node")`)
//! without depending on where cargo put `seam`.

use std::process::ExitCode;

use clap::Parser;
use seam_bench::bridge::{self, BridgeArgs};
use seam_bench::node::{self, NodeArgs};

#[derive(Parser)]
struct NodeCli {
    #[command(flatten)]
    args: NodeArgs,
}

#[derive(Parser)]
struct BridgeCli {
    #[command(flatten)]
    args: BridgeArgs,
}

fn main() -> ExitCode {
    let result = if std::env::args().nth(1).as_deref() == Some("bridge") {
        let args = BridgeCli::parse_from(std::env::args().skip(1)).args;
        node::stop_flag()
            .and_then(|stop| bridge::run_bridge(&args, &stop, &mut std::io::stdout().lock()))
            .map(|_| ())
    } else {
        let args = NodeCli::parse().args;
        node::stop_flag()
            .and_then(|stop| node::run_node(&args, &stop, &mut std::io::stdout().lock()))
            .map(|_| ())
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("seam-test-node: {e}");
            ExitCode::FAILURE
        }
    }
}
