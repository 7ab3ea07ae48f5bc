//! One module per `seam` command: its flags (as clap reads them) and what it does beyond
//! calling its part of `seam_bench` — progress on stderr, printing what was measured, the exit
//! status. What several commands share is here.

pub(crate) mod bridge;
pub(crate) mod capacity;
pub(crate) mod chaos;
pub(crate) mod compare;
pub(crate) mod inspect;
pub(crate) mod keys;
pub(crate) mod network;
pub(crate) mod node;
pub(crate) mod ops;
pub(crate) mod ping;
pub(crate) mod run;
pub(crate) mod scene;
pub(crate) mod sweep;
pub(crate) mod throughput;

use std::ffi::OsString;
use std::path::PathBuf;
use std::time::Duration;

use seam_bench::console::Progress;
use seam_bench::error::{BenchError, BenchResult};
use seam_bench::scene::Scene;

/// `redis` alone is shorthand for the local default server.
pub(crate) fn expand_transport(name: &str) -> String {
    match name {
        "redis" => "redis://127.0.0.1:6379".to_owned(),
        other => other.to_owned(),
    }
}

/// Progress through `total` rows, one step per row (see [`Progress`]).
pub(crate) fn progress(total: usize) -> impl FnMut(&str) {
    let mut progress = Progress::new(Some(total as u64));
    move |row| progress.step(row)
}

/// Progress through trials whose number the callee learns first (`sweep`, `network`).
pub(crate) fn trial_progress() -> impl FnMut(usize, usize, &str) {
    let mut progress = None;
    move |_, total, line| {
        progress
            .get_or_insert_with(|| Progress::new(Some(total as u64)))
            .step(line);
    }
}

/// How `seam run`, `chaos`, `sweep` and `network` start a pod: this executable's `node`
/// command.
pub(crate) fn node_command() -> BenchResult<Vec<OsString>> {
    let exe = std::env::current_exe()
        .map_err(|e| BenchError::io("find", "the seam executable itself", e))?;
    Ok(vec![exe.into(), "node".into()])
}

/// `value` seconds (clap has checked it is a number; negative or not finite becomes 0, which
/// the caller refuses).
pub(crate) fn seconds(value: f64) -> Duration {
    Duration::try_from_secs_f64(value).unwrap_or_default()
}

/// Each scene file loaded and kept with its path; `defaults` (names in bench/scenes/) when
/// none is given.
pub(crate) fn load_scenes(
    paths: Vec<PathBuf>,
    defaults: &[&str],
) -> BenchResult<Vec<(PathBuf, Scene)>> {
    let paths = if paths.is_empty() {
        defaults
            .iter()
            .map(|name| format!("bench/scenes/{name}.toml").into())
            .collect()
    } else {
        paths
    };
    paths
        .into_iter()
        .map(|path| match seam_bench::scene::load(&path) {
            Ok(scene) => Ok((path, scene)),
            Err(e) => {
                Err(BenchError::from(e).hint("run from the repository root, or pass --scene FILE"))
            }
        })
        .collect()
}
