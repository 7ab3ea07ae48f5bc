//! `seam ops`: routed-op latency between two processes, stage by stage, per transport; and
//! the owning side it starts.

use seam_bench::error::BenchResult;
use seam_bench::ops::{self, OpsPlan};
use seam_bench::ping::WaitMode;

use super::{expand_transport, progress};
use crate::cli::Output;

/// `seam ops`'s flags.
#[derive(clap::Args)]
pub(crate) struct OpsArgs {
    /// Transports to compare, comma separated (`redis` alone means redis://127.0.0.1:6379).
    #[arg(long, default_value = "shm", value_delimiter = ',')]
    transport: Vec<String>,
    /// Ops per frame, comma separated.
    #[arg(long, default_value = "1,16,256", value_delimiter = ',')]
    batch: Vec<usize>,
    /// Answers carried in each frame, comma separated: `off` (none) and `on` (one per op of
    /// the batch, as a pod's frame carries its answers to the ops the other side sent it).
    /// Both, measured in turn, give the cost of acknowledgements as a ratio in one run;
    /// repeat them (`off,on,off,on,off,on`) and the ratio is of the medians.
    #[arg(long, default_value = "off,on", value_delimiter = ',')]
    acks: Vec<AckMode>,
    /// Timed frames per row.
    #[arg(long, default_value_t = 10_000)]
    rounds: u64,
    /// Untimed frames before them.
    #[arg(long, default_value_t = 1_000)]
    warmup: u64,
    /// How both sides wait: auto spins on shared memory and sleeps on Redis.
    #[arg(long, value_enum, default_value_t = WaitMode::Auto)]
    wait: WaitMode,
    #[command(flatten)]
    output: Output,
}

/// Whether `seam ops` frames carry answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum AckMode {
    /// None.
    Off,
    /// One per op of the batch.
    On,
}

/// The owning side of `seam ops` (started by it).
#[derive(clap::Args)]
pub(crate) struct OwnerArgs {
    #[arg(long)]
    transport: String,
    #[arg(long)]
    events: String,
    #[arg(long)]
    ack: String,
    #[arg(long, value_enum)]
    wait: WaitMode,
}

/// Every transport, batch size and answer mode, with progress, then the rows printed.
pub(crate) fn main(args: &OpsArgs) -> BenchResult<()> {
    let mut acks: Vec<bool> = args.acks.iter().map(|&a| a == AckMode::On).collect();
    acks.dedup();
    let plan = OpsPlan {
        transports: args.transport.iter().map(|t| expand_transport(t)).collect(),
        batches: args.batch.clone(),
        acks,
        rounds: args.rounds,
        warmup: args.warmup,
        wait: args.wait,
    };
    let total = plan.transports.len() * plan.batches.len() * plan.acks.len();
    eprintln!(
        "seam ops: {} timed frames per row after {} warm-up, one frame in flight",
        args.rounds, args.warmup
    );
    let rows = ops::run(&plan, progress(total))?;
    args.output.rows(&rows, ops::document);
    Ok(())
}

/// Applies every op as it arrives and acknowledges each frame.
pub(crate) fn owner(args: &OwnerArgs) -> BenchResult<()> {
    ops::run_owner(&args.transport, &args.events, &args.ack, args.wait)
}
