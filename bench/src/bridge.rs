//! `seam bridge`: one host's bridge between its pods' shared memory and the deployment's Redis
//! server (see `seam_proxy::Bridge` for what it passes on and why).
//!
//! It writes JSON lines on stdout — [`BridgeLine::Ready`] once both directions are open and
//! subscribed, then its report when SIGINT or SIGTERM stops it — so `seam run --hosts N` can
//! start pods only once the bridges listen, and add the bridges' traffic and CPU to its report.

use std::collections::HashMap;
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use seam_proxy::{Bridge, BridgeRoutes, DirectionStats};
use seam_sim::wire::ClusterId;

use crate::error::{BenchError, BenchResult};
use crate::pod::SceneIds;
use crate::scene::Scene;

/// `seam bridge` flags.
#[derive(Debug, Clone, clap::Args)]
pub struct BridgeArgs {
    /// The scene file (TOML): its clusters, their neighbours and their hosts.
    pub scene: PathBuf,
    /// The host this bridge serves (a scene `host`, or `a`, `b`, … of `--hosts N`).
    #[arg(long)]
    pub host: String,
    /// Lay the clusters out on this many hosts (for a scene that names none; see
    /// `Scene::host_layout`).
    #[arg(long)]
    pub hosts: Option<u32>,
    /// The run id the pods were given (cluster ids, hence channel names, derive from it).
    #[arg(long, default_value = "seam")]
    pub run_id: String,
    /// This host's shared memory: the URL its pods use (e.g. `shm?prefix=seam_a_`).
    #[arg(long)]
    pub local: String,
    /// The Redis server between hosts. Read from `SEAM_REDIS` when the flag is not given, so a
    /// password does not show in the process list.
    #[arg(long, env = "SEAM_REDIS", default_value = "redis://127.0.0.1:6379")]
    pub remote: String,
}

/// A line `seam bridge` writes.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BridgeLine {
    /// Both directions are open and subscribed.
    Ready {
        /// The host.
        host: String,
        /// Channels passed out and in.
        channels_out: usize,
        /// Channels passed in.
        channels_in: usize,
    },
    /// The end of the run.
    Report(BridgeReport),
}

/// What a bridge did.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct BridgeReport {
    /// The host it served.
    pub host: String,
    /// Shared memory → Redis.
    pub out: DirectionStats,
    /// Redis → shared memory.
    pub into: DirectionStats,
    /// Seconds from ready to stop.
    pub wall_s: f64,
    /// CPU time of the whole process (both directions), seconds.
    pub cpu_s: f64,
}

impl BridgeReport {
    /// CPU time over wall time: the share of one core the bridge used.
    pub fn core_share(&self) -> f64 {
        if self.wall_s > 0.0 {
            self.cpu_s / self.wall_s
        } else {
            0.0
        }
    }
}

/// The channels the bridge of `host` passes on, in run `run_id` of `scene` laid out on
/// `hosts` hosts (see [`Scene::host_layout`]).
pub fn routes(
    scene: &Scene,
    hosts: Option<u32>,
    run_id: &str,
    host: &str,
) -> BenchResult<BridgeRoutes> {
    let layout = scene.host_layout(hosts)?;
    if !layout.iter().any(|h| h == host) {
        let mut known = layout.clone();
        known.dedup();
        return Err(BenchError::flag(
            "--host",
            format!(
                "scene {:?} has no host {host:?} (hosts: {})",
                scene.name,
                known.join(", ")
            ),
        ));
    }
    let ids = SceneIds::new(run_id, &scene.name);
    let clusters: HashMap<String, ClusterId> = scene
        .clusters
        .iter()
        .map(|c| (c.name.clone(), ids.cluster(&c.name)))
        .collect();
    let host_of: HashMap<ClusterId, &str> = scene
        .clusters
        .iter()
        .zip(&layout)
        .map(|(c, h)| (clusters[&c.name], h.as_str()))
        .collect();
    let world = crate::pod::scene_world_map(scene, &clusters);
    Ok(BridgeRoutes::for_host(&world, |id| {
        host_of.get(&id) == Some(&host)
    }))
}

/// The shared-memory URL of `host`: `url` (an `shm` URL) with its prefix made the host's own,
/// so no shared memory crosses simulated hosts.
pub fn host_url(url: &str, host: &str) -> BenchResult<String> {
    let (scheme, query) = url.split_once('?').unwrap_or((url, ""));
    if scheme != "shm" {
        return Err(BenchError::flag(
            "--transport",
            format!(
                "several hosts need the pods on `shm` (each host's own shared memory; Redis \
                 between hosts), not {:?}",
                seam_transport::redact_url(url)
            ),
        ));
    }
    let mut prefix = "seam_".to_owned();
    let mut rest = Vec::new();
    for pair in query.split('&').filter(|p| !p.is_empty()) {
        match pair.split_once('=') {
            Some(("prefix", value)) => prefix = value.to_owned(),
            _ => rest.push(pair),
        }
    }
    rest.push("");
    let others = rest.join("&");
    Ok(format!("shm?{others}prefix={prefix}{host}_"))
}

/// Runs a bridge until `stop` is set; writes its lines to `out`.
pub fn run_bridge(
    args: &BridgeArgs,
    stop: &AtomicBool,
    out: &mut impl Write,
) -> BenchResult<BridgeReport> {
    let scene = crate::scene::load(&args.scene)?;
    let routes = routes(&scene, args.hosts, &args.run_id, &args.host)?;
    let mut bridge = Bridge::start(&args.local, &args.remote, &routes)?;
    emit(
        out,
        &BridgeLine::Ready {
            host: args.host.clone(),
            channels_out: routes.out.len(),
            channels_in: routes.into.len(),
        },
    )?;
    tracing::info!(
        host = args.host,
        channels_out = routes.out.len(),
        channels_in = routes.into.len(),
        remote = %seam_transport::redact_url(&args.remote),
        "bridge ready"
    );
    let (started, cpu_start) = (Instant::now(), process_cpu());
    while !stop.load(Ordering::Relaxed) && !bridge.has_failed() {
        std::thread::sleep(Duration::from_millis(50));
    }
    let result = bridge.stop();
    let report = BridgeReport {
        host: args.host.clone(),
        out: bridge.out.snapshot(),
        into: bridge.into.snapshot(),
        wall_s: started.elapsed().as_secs_f64(),
        cpu_s: (process_cpu() - cpu_start).as_secs_f64(),
    };
    result?;
    emit(out, &BridgeLine::Report(report.clone()))?;
    Ok(report)
}

/// CPU time of this process, all threads.
fn process_cpu() -> Duration {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ProcessCPUTime);
    Duration::new(
        t.tv_sec.max(0) as u64,
        t.tv_nsec.clamp(0, 999_999_999) as u32,
    )
}

fn emit(out: &mut impl Write, line: &BridgeLine) -> BenchResult<()> {
    let text = serde_json::to_string(line)?;
    writeln!(out, "{text}")
        .and_then(|()| out.flush())
        .map_err(|e| BenchError::io("write to", "stdout", e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_urls_keep_settings_and_own_the_prefix() {
        assert_eq!(
            host_url("shm", "a").expect("a shm url"),
            "shm?prefix=seam_a_"
        );
        assert_eq!(
            host_url("shm?buffer=64&prefix=run7_", "b").expect("a shm url"),
            "shm?buffer=64&prefix=run7_b_"
        );
        assert!(host_url("redis://127.0.0.1:6379", "a").is_err());
        assert!(host_url("local", "a").is_err());
    }
}
