//! `seam chaos`: a scene's pods under faults on a schedule, and what survived.

use std::path::PathBuf;
use std::time::Duration;

use seam_bench::chaos::{Broker, ChaosPlan};
use seam_bench::console::Progress;
use seam_bench::error::{BenchError, BenchResult};
use seam_bench::node;
use seam_bench::record::PartsDir;

use super::{node_command, seconds};
use crate::cli::Output;

/// `seam chaos`'s flags.
#[derive(clap::Args)]
pub(crate) struct ChaosArgs {
    /// The scene file (TOML), e.g. bench/scenes/crossfire.toml.
    scene: PathBuf,
    /// `shm`; `redis` for a private redis-server (needs `redis-server` on the PATH), killed
    /// and restarted among the faults; or `redis-cluster` for a private Redis Cluster made by
    /// tools/redis-cluster (three primaries, three replicas), whose faults add a primary
    /// killed (its replica takes over) and the slot of a live channel moved.
    #[arg(long, default_value = "shm", value_parser = ["shm", "redis", "redis-cluster"])]
    transport: String,
    /// How long the pods run, seconds.
    #[arg(long, default_value_t = 60.0)]
    duration_s: f64,
    /// Seconds from the end of one fault to the start of the next.
    #[arg(long, default_value_t = 5.0)]
    fault_every_s: f64,
    /// Ticks per second.
    #[arg(long, default_value_t = 60.0)]
    rate: f64,
    /// Stack this many copies of every grid entity along y.
    #[arg(long, default_value_t = 1)]
    layers: u32,
    /// Seeds which pod each fault hits and the garbage.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Give the pods this frame key (`key=` in their URL): the injector, a process without
    /// it, must then see every garbage and forged frame dropped as untagged before any
    /// decoder reads it.
    #[arg(long)]
    key: Option<String>,
    /// Record every pod incarnation's ticks and the faults into FILE (see `seam inspect`).
    #[arg(long, value_name = "FILE")]
    record: Option<PathBuf>,
    #[command(flatten)]
    output: Output,
}

impl ChaosArgs {
    fn plan(&self) -> BenchResult<ChaosPlan> {
        let (duration, fault_every) = (seconds(self.duration_s), seconds(self.fault_every_s));
        if duration < Duration::from_secs(10) {
            return Err(BenchError::flag("--duration-s", "must be at least 10"));
        }
        if fault_every < Duration::from_secs(2) {
            return Err(BenchError::flag(
                "--fault-every-s",
                "must be at least 2 (a fault needs its quiet second)",
            ));
        }
        Ok(ChaosPlan {
            scene: self.scene.clone(),
            broker: match self.transport.as_str() {
                "redis" => Broker::Redis,
                "redis-cluster" => Broker::RedisCluster,
                _ => Broker::Shm,
            },
            rate: self.rate,
            duration,
            fault_every,
            layers: self.layers,
            seed: self.seed,
            node_command: node_command()?,
            key: self.key.clone(),
            record_dir: None,
        })
    }
}

/// Runs the plan, writes the recording if asked, prints the report, and fails if a target did
/// not hold.
pub(crate) fn main(args: &ChaosArgs) -> BenchResult<()> {
    let mut plan = args.plan()?;
    let stop = node::stop_flag()?;
    eprintln!(
        "seam chaos: {} for {:.0} s, a fault every {:.0} s",
        plan.scene.display(),
        plan.duration.as_secs_f64(),
        plan.fault_every.as_secs_f64()
    );
    let record = args.record.as_deref();
    let parts = match record {
        Some(out) => Some(PartsDir::beside(Some(out))?),
        None => None,
    };
    plan.record_dir = parts.as_ref().map(|p| p.dir.clone());
    let progress = Progress::new(None);
    let report = seam_bench::chaos::run(&plan, &stop, |line| progress.status(line))?;
    drop(progress);
    if let (Some(parts), Some(out)) = (&parts, record) {
        let summary = parts.merge_into(out, &report.fault_log, "seam chaos")?;
        eprintln!("seam chaos: {}", summary.line(out));
    }
    args.output.report(&report, seam_bench::chaos::document);
    if report.holds() {
        Ok(())
    } else {
        Err(BenchError::Failed(
            "seam chaos: a target did not hold (see the report)".to_owned(),
        ))
    }
}
