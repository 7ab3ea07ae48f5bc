//! `seam compare`: one setting against the single-world reference, a trial per scene.

use std::path::PathBuf;

use seam_bench::accuracy::{self, TrialSettings};
use seam_bench::console::Progress;
use seam_bench::error::{BenchError, BenchResult};
use seam_bench::node::ModelArgs;

use crate::cli::Output;

/// `seam compare`'s flags.
#[derive(clap::Args)]
pub(crate) struct CompareArgs {
    /// The scene files (TOML), each compared in turn.
    #[arg(required = true)]
    scenes: Vec<PathBuf>,
    #[command(flatten)]
    knobs: Knobs,
    /// Print, on stderr after every tick, where this entity (its scene name; `name#i` for
    /// a grid copy, as the "largest" line names it; `shot:E.S` for shot S of the scene's
    /// event E, counted from 0, as the hand-offs line names it) is in the split run and in
    /// the single world, which cluster simulates it, and how far apart the two are.
    #[arg(long, value_name = "NAME")]
    trace: Option<String>,
    /// Record the split run and the single world, tick by tick, into FILE (one scene
    /// only): `seam inspect FILE` then shows each body's distance from its single-world
    /// copy.
    #[arg(long, value_name = "FILE")]
    record: Option<PathBuf>,
    #[command(flatten)]
    output: Output,
}

/// The settings `seam compare` tries.
#[derive(clap::Args)]
struct Knobs {
    #[command(flatten)]
    model: ModelArgs,
    /// Observation spread of every cluster, m (default: the scene's).
    #[arg(long)]
    spread: Option<f32>,
    /// Proxy every neighbour entity wherever it is (no interest management).
    #[arg(long)]
    everything: bool,
    /// Speed of the scene's projectiles, m/s (default: the scene's).
    #[arg(long)]
    speed: Option<f32>,
    /// CCD on the scene's projectiles: `on` or `off` (default: the scene's).
    #[arg(long, value_parser = ["on", "off"])]
    ccd: Option<String>,
    /// Ticks (default: the scene's).
    #[arg(long)]
    ticks: Option<u64>,
}

impl Knobs {
    fn settings(&self) -> TrialSettings {
        TrialSettings {
            proxy_mode: self.model.proxy_mode.into(),
            authority: self.model.authority,
            replication_interval: self.model.replication_interval.max(1),
            coupling: !self.model.no_coupling,
            exchange: !self.model.no_exchange,
            quantize: self.model.quantize,
            keyframe_ticks: self.model.keyframe_ticks,
            spread: self.spread,
            interest: !self.everything,
            projectile_speed: self.speed,
            projectile_ccd: self.ccd.as_deref().map(|c| c == "on"),
            ticks: self.ticks,
        }
    }
}

/// One trial per scene; with `--json` each result as it ends, else one document at the end
/// (with `--markdown`, one table with a row each).
pub(crate) fn main(args: &CompareArgs) -> BenchResult<()> {
    let record = args.record.as_deref();
    if record.is_some() && args.scenes.len() != 1 {
        return Err(BenchError::flag(
            "--record",
            "writes one recording: give one scene",
        ));
    }
    let settings = args.knobs.settings();
    let mut results = Vec::new();
    let mut progress = Progress::new(Some(args.scenes.len() as u64));
    for path in &args.scenes {
        progress.status(&format!("{}: split and one world", path.display()));
        let scene = seam_bench::scene::load(path)?;
        let result =
            accuracy::run_recorded_trial(&scene, &settings, args.trace.as_deref(), record)?;
        if let Some(out) = record {
            let size = std::fs::metadata(out).map(|m| m.len()).unwrap_or(0);
            eprintln!(
                "seam compare: recorded the split run and the single world: {:.1} MB -> {}",
                size as f64 / 1e6,
                out.display()
            );
        }
        progress.step(&path.display().to_string());
        if args.output.json {
            println!("{}", serde_json::to_string_pretty(&result)?);
        }
        results.push(result);
    }
    if !args.output.json {
        args.output.print(&accuracy::document(&results));
    }
    Ok(())
}
