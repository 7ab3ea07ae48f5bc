//! `seam node`: one cluster pod (started by `seam run`, or by hand on each host).

use seam_bench::error::BenchResult;
use seam_bench::node::{self, NodeArgs};

/// Runs the pod until its ticks are done or SIGINT/SIGTERM; its JSON lines go to stdout.
pub(crate) fn main(args: &NodeArgs) -> BenchResult<()> {
    let stop = node::stop_flag()?;
    node::run_node(args, &stop, &mut std::io::stdout().lock())?;
    Ok(())
}
