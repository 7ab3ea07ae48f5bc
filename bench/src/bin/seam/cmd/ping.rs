//! `seam ping`: one-way latency between two processes over each transport, beside the
//! plain-iceoryx2 floor; and the peer sides it starts.

use seam_bench::error::BenchResult;
use seam_bench::ping::{self, PingPlan, WaitMode};

use super::{expand_transport, progress};
use crate::cli::Output;

/// `seam ping`'s flags.
#[derive(clap::Args)]
pub(crate) struct PingArgs {
    /// Transports to compare, comma separated, e.g. `shm,redis://127.0.0.1:6379`.
    /// `redis` alone means redis://127.0.0.1:6379.
    #[arg(long, default_value = "shm", value_delimiter = ',')]
    transport: Vec<String>,
    /// Payload sizes in bytes, comma separated.
    #[arg(long, default_value = "64", value_delimiter = ',')]
    size: Vec<usize>,
    /// Timed round trips per row.
    #[arg(long, default_value_t = 20_000)]
    iterations: u64,
    /// Untimed round trips before them.
    #[arg(long, default_value_t = 2_000)]
    warmup: u64,
    /// How both sides wait for a message: auto spins on shared memory and sleeps on Redis.
    #[arg(long, value_enum, default_value_t = WaitMode::Auto)]
    wait: WaitMode,
    #[command(flatten)]
    output: Output,
    /// Skip the plain-iceoryx2 floor rows.
    #[arg(long)]
    no_floor: bool,
}

/// The peer side of `seam ping` (started by it).
#[derive(clap::Args)]
pub(crate) struct PeerArgs {
    #[arg(long)]
    transport: String,
    #[arg(long)]
    ping: String,
    #[arg(long)]
    pong: String,
    #[arg(long)]
    count: u64,
    #[arg(long, value_enum)]
    wait: WaitMode,
}

/// The peer side of the plain-iceoryx2 floor (started by `seam ping`).
#[derive(clap::Args)]
pub(crate) struct FloorPeerArgs {
    #[arg(long)]
    ping: String,
    #[arg(long)]
    pong: String,
    #[arg(long)]
    size: usize,
    #[arg(long)]
    count: u64,
}

/// Every transport at every size, with progress, then the rows printed.
pub(crate) fn main(args: &PingArgs) -> BenchResult<()> {
    let plan = PingPlan {
        transports: args.transport.iter().map(|t| expand_transport(t)).collect(),
        sizes: args.size.clone(),
        iterations: args.iterations,
        warmup: args.warmup,
        wait: args.wait,
        floor: !args.no_floor,
    };
    let shm = plan
        .transports
        .iter()
        .filter(|t| *t == "shm" || t.starts_with("shm?"))
        .count();
    let rows_per_size = plan.transports.len() + if plan.floor { shm } else { 0 };
    eprintln!(
        "seam ping: {} timed round trips per row after {} warm-up, one-way = round trip / 2, {} cores",
        args.iterations,
        args.warmup,
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    let rows = ping::run(&plan, progress(rows_per_size * plan.sizes.len()))?;
    args.output.rows(&rows, ping::document);
    Ok(())
}

/// Echoes every ping back.
pub(crate) fn peer(args: &PeerArgs) -> BenchResult<()> {
    ping::run_peer(
        &args.transport,
        &args.ping,
        &args.pong,
        args.count,
        args.wait,
    )
}

/// Echoes every ping back on plain iceoryx2.
pub(crate) fn floor_peer(args: &FloorPeerArgs) -> BenchResult<()> {
    ping::run_floor_peer(&args.ping, &args.pong, args.size, args.count)
}
