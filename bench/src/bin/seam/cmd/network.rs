//! `seam network`: accuracy against a simulated delay between two hosts.

use std::path::PathBuf;

use seam_bench::error::{BenchError, BenchResult};
use seam_bench::network::NetworkPlan;

use super::{expand_transport, load_scenes, node_command, trial_progress};

/// `seam network`'s flags.
#[derive(clap::Args)]
pub(crate) struct NetworkArgs {
    /// Scene files (default: crossfire and gallery of bench/scenes/).
    #[arg(long = "scene")]
    scenes: Vec<PathBuf>,
    /// One-way delays between host b and Redis, ms, comma separated.
    #[arg(long, default_value = "0,1,5,20", value_delimiter = ',')]
    delays_ms: Vec<f64>,
    /// Up to this much more per chunk, ms, uniformly at random (order kept).
    #[arg(long, default_value_t = 0.0)]
    jitter_ms: f64,
    /// Ticks per second of the pods.
    #[arg(long, default_value_t = 60.0)]
    rate: f64,
    /// Stagger the two pods by half a period (default: in phase, as `seam run`).
    #[arg(long)]
    stagger: bool,
    /// Routed ops go after the step and land a tick late (default: exchanged before it, as
    /// `seam run`; a delay past the quarter tick each pod waits for the other's misses that
    /// too).
    #[arg(long)]
    no_exchange: bool,
    /// The Redis server between hosts (on this machine's loopback).
    #[arg(long, default_value = "redis://127.0.0.1:6379")]
    redis: String,
    /// Where to write the CSV and the charts.
    #[arg(long, default_value = "network")]
    out: PathBuf,
}

/// Every scene at every delay, printed, then the files written.
pub(crate) fn main(args: &NetworkArgs) -> BenchResult<()> {
    let delays_ok = args.delays_ms.iter().all(|d| d.is_finite() && *d >= 0.0);
    if !delays_ok || !args.jitter_ms.is_finite() || args.jitter_ms < 0.0 {
        return Err(BenchError::flag(
            "--delays-ms, --jitter-ms",
            "must be non-negative numbers",
        ));
    }
    let plan = NetworkPlan {
        scenes: load_scenes(args.scenes.clone(), &["crossfire", "gallery"])?,
        delays_ms: args.delays_ms.clone(),
        jitter_ms: args.jitter_ms,
        rate: args.rate,
        stagger: args.stagger,
        exchange: !args.no_exchange,
        redis: expand_transport(&args.redis),
        node_command: node_command()?,
    };
    let trials = seam_bench::network::run(&plan, trial_progress())?;
    print!("{}", seam_bench::network::document(&trials).text());
    for path in seam_bench::network::write(&trials, &args.out)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}
