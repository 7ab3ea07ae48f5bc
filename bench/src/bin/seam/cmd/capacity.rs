//! `seam capacity`: the largest size of a scene each configuration holds at the rate.

use std::path::PathBuf;

use seam_bench::capacity::{self, CapacityPlan, Row};
use seam_bench::error::{BenchError, BenchResult};

use super::node_command;
use crate::cli::Output;

/// `seam capacity`'s flags.
#[derive(clap::Args)]
pub(crate) struct CapacityArgs {
    /// The scene file (TOML), e.g. bench/scenes/grid.toml; its size grows by layers (every
    /// grid entity repeated along y).
    scene: PathBuf,
    /// The rows, in order, the first the one the others are compared with: `rapier` (plain
    /// Rapier, one thread), `rapier-ed` (with enhanced-determinism, as seam's worlds),
    /// `parallel` and `parallel-ed` (Rapier's parallel feature, every core), `apart:N` (the
    /// scene cut in N as seam:N cuts it, each part a plain world in its own process, all at
    /// once, nothing crossing: the most any split over N processes could hold here), `seam:N`
    /// (N pods on shared memory). Default: rapier, parallel, parallel-ed, apart:CORES,
    /// seam:CORES, seam:4.
    #[arg(long, value_delimiter = ',', value_parser = Row::parse)]
    rows: Vec<Row>,
    /// Ticks each probe runs.
    #[arg(long, default_value_t = 900)]
    ticks: u64,
    /// Ticks per second to hold.
    #[arg(long, default_value_t = 60.0)]
    rate: f64,
    /// The largest share of ticks that may take longer than the period for a size to hold, in
    /// each pod (each world apart) on its own (0.001: 0.1 %, none of 900).
    #[arg(long, default_value_t = 0.001)]
    max_overrun: f64,
    /// The most layers tried.
    #[arg(long, default_value_t = 64)]
    max_layers: u32,
    /// Where to write the chart (capacity_SCENE.svg and .png).
    #[arg(long, default_value = "capacity")]
    out: PathBuf,
    #[command(flatten)]
    output: Output,
}

/// Runs the search, one line per probe on stderr, then the table (or JSON) and the chart.
pub(crate) fn main(args: &CapacityArgs) -> BenchResult<()> {
    if args.ticks == 0 {
        return Err(BenchError::flag("--ticks", "must be at least 1"));
    }
    let plan = CapacityPlan {
        scene: args.scene.clone(),
        rows: if args.rows.is_empty() {
            capacity::default_rows()
        } else {
            args.rows.clone()
        },
        ticks: args.ticks,
        rate: args.rate,
        max_overrun: args.max_overrun,
        max_layers: args.max_layers,
        node_command: node_command()?,
    };
    let report = capacity::run(&plan, |probe| {
        eprintln!(
            "  {}: {} layers, {} bodies: wall p50 {:.2} ms, p99 {:.2} ms, CPU p50 {:.2} ms; {} of {} \
             ticks over ({:.2} % in the worst of {} processes): {}",
            probe.row,
            probe.layers,
            probe.bodies,
            probe.wall_p50_ns as f64 / 1e6,
            probe.wall_p99_ns as f64 / 1e6,
            probe.cpu_p50_ns as f64 / 1e6,
            probe.overruns,
            probe.ticks,
            probe.worst_overrun_share * 100.0,
            probe.processes,
            if probe.holds {
                "holds"
            } else {
                "does not hold"
            }
        );
    })?;
    args.output.report(&report, capacity::document);
    let [svg, png] = capacity::draw(&report, &args.out)?;
    eprintln!(
        "seam capacity: wrote {} and {}",
        svg.display(),
        png.display()
    );
    Ok(())
}
