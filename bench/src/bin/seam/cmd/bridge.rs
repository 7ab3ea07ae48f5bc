//! `seam bridge`: one host's bridge between its pods' shared memory and Redis.

use seam_bench::bridge::{self, BridgeArgs};
use seam_bench::error::BenchResult;
use seam_bench::node;

/// Runs the bridge until SIGINT/SIGTERM; its JSON lines go to stdout.
pub(crate) fn main(args: &BridgeArgs) -> BenchResult<()> {
    let stop = node::stop_flag()?;
    bridge::run_bridge(args, &stop, &mut std::io::stdout().lock())?;
    Ok(())
}
