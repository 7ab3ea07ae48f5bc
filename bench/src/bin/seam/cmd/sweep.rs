//! `seam sweep`: settings against the single-world reference, written as `sweep.csv` and
//! charts.

use std::path::PathBuf;

use seam_bench::accuracy::FreeRunning;
use seam_bench::error::BenchResult;
use seam_bench::run::HostsPlan;
use seam_bench::sweep::SweepGrid;

use super::{expand_transport, load_scenes, node_command, trial_progress};

/// The scenes swept when none is named.
const DEFAULT_SCENES: [&str; 8] = [
    "gallery",
    "corridor",
    "stacks",
    "light-on-heavy",
    "equal-masses",
    "seam-stack",
    "grid",
    "crossfire",
];

/// `seam sweep`'s flags.
#[derive(clap::Args)]
pub(crate) struct SweepArgs {
    /// Scene files (default: gallery, corridor, stacks, light-on-heavy, equal-masses,
    /// seam-stack, grid and crossfire of bench/scenes/).
    #[arg(long = "scene")]
    scenes: Vec<PathBuf>,
    /// A reduced grid: fixed/kinematic × interval 1, 4 × 50, 500, 2 000 m/s × CCD off/on ×
    /// spread 3 m / everything, and exact/quantized.
    #[arg(long)]
    quick: bool,
    /// Ticks per trial (default: each scene's).
    #[arg(long)]
    ticks: Option<u64>,
    /// Transports for the free-running pods of the transport axis, comma separated
    /// (`redis` alone means redis://127.0.0.1:6379; one that cannot be opened is left out
    /// with a notice; `none` skips the axis).
    #[arg(long, default_value = "shm,redis", value_delimiter = ',')]
    transport: Vec<String>,
    /// Ticks per second of the free-running pods.
    #[arg(long, default_value_t = 240.0)]
    rate: f64,
    /// Where to write the CSV and the charts.
    #[arg(long, default_value = "sweep")]
    out: PathBuf,
}

/// Every trial of the grid on every scene, then the files written.
pub(crate) fn main(args: &SweepArgs) -> BenchResult<()> {
    let scenes = load_scenes(args.scenes.clone(), &DEFAULT_SCENES)?;
    let mut grid = if args.quick {
        SweepGrid::quick()
    } else {
        SweepGrid::full()
    };
    for transport in args
        .transport
        .iter()
        .filter(|t| t.as_str() != "none")
        .map(|t| expand_transport(t))
    {
        match seam_transport::open(&transport) {
            Ok(_) => grid.transports.push(transport),
            Err(e) => tracing::warn!("seam sweep: leaving out the transport axis on {e}"),
        }
    }
    let free = FreeRunning {
        rate: args.rate,
        node_command: node_command()?,
        hosts: HostsPlan::default(),
        stagger: false,
    };
    let results = seam_bench::sweep::run(&scenes, &grid, args.ticks, &free, trial_progress())?;
    for path in seam_bench::sweep::write(&results, &args.out)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}
