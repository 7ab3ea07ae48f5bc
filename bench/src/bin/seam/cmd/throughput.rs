//! `seam throughput`: messages a second through one Redis server and Redis Clusters, with each
//! server's CPU.

use std::time::Duration;

use seam_bench::error::{BenchError, BenchResult};
use seam_bench::throughput::{self, Target, ThroughputPlan};

use super::progress;
use crate::cli::Output;

/// `seam throughput`'s flags.
#[derive(clap::Args)]
pub(crate) struct ThroughputArgs {
    /// What carries the load, comma separated: `server` (a private redis-server) and
    /// `cluster:N` (a private Redis Cluster of N primaries, 1 to 3, each with a replica, made
    /// by tools/redis-cluster).
    #[arg(
        long,
        default_value = "server,cluster:1,cluster:3",
        value_delimiter = ','
    )]
    targets: Vec<String>,
    /// Offered loads, messages a second from all publishers together, comma separated.
    #[arg(
        long,
        default_value = "10000,20000,40000,80000,160000",
        value_delimiter = ','
    )]
    rates: Vec<u64>,
    /// Seconds each load is offered.
    #[arg(long, default_value_t = 3.0)]
    seconds: f64,
    /// Channels the load is spread over (`load:{I}`: hash tags, so over a cluster's slots).
    #[arg(long, default_value_t = 48)]
    channels: usize,
    /// Publisher threads, each with its own transport.
    #[arg(long, default_value_t = 2)]
    publishers: usize,
    /// Subscriber threads, each subscribed to every channel.
    #[arg(long, default_value_t = 2)]
    subscribers: usize,
    /// Payload bytes.
    #[arg(long, default_value_t = 256)]
    size: usize,
    #[command(flatten)]
    output: Output,
}

/// Every target at every load, with progress, then the rows printed.
pub(crate) fn main(args: &ThroughputArgs) -> BenchResult<()> {
    let targets = args
        .targets
        .iter()
        .map(|t| {
            Target::parse(t).ok_or_else(|| {
                BenchError::flag(
                    "--targets",
                    format!("{t:?} is not `server` or `cluster:N` with N from 1 to 3"),
                )
            })
        })
        .collect::<BenchResult<Vec<_>>>()?;
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        return Err(BenchError::flag("--seconds", "must be positive"));
    }
    if args.publishers == 0 || args.subscribers == 0 || args.rates.contains(&0) {
        return Err(BenchError::flag(
            "--publishers, --subscribers, --rates",
            "must be positive",
        ));
    }
    let plan = ThroughputPlan {
        targets,
        rates: args.rates.clone(),
        window: Duration::from_secs_f64(args.seconds),
        channels: args.channels,
        publishers: args.publishers,
        subscribers: args.subscribers,
        size: args.size,
    };
    eprintln!(
        "seam throughput: {} publishers and {} subscribers (each on every one of {} channels), \
         {} B payloads, {} s a load, {} cores",
        plan.publishers,
        plan.subscribers,
        plan.channels,
        plan.size,
        args.seconds,
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    let rows = throughput::run(&plan, progress(plan.targets.len() * plan.rates.len()))?;
    args.output.rows(&rows, throughput::document);
    Ok(())
}
