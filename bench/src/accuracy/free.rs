//! The transport axis: a scene's clusters as free-running pod processes (`seam run`) on shm or
//! Redis, compared with a single-world reference run in this process.
//!
//! Free-running pods are not deterministic (what a pod sees depends on when frames arrive), so
//! only what they report at the end is compared: projectile hits (pairs and ticks) and where
//! every dynamic body ended. Cost comes from the run's report: tick times, bytes, proxies, and
//! routed-op latency stage by stage, which is what the transport changes.

use std::ffi::OsString;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use seam_sim::wire::{EntityId, IdMap};

use super::{Accuracy, Cost, TrialResult, TrialSettings};
use crate::node::ProxyModeArg;
use crate::pod::{Part, Pod, PodSettings};
use crate::run::{self, RunPlan};
use crate::scene::Scene;

/// How free-running trials start their pods.
#[derive(Debug, Clone)]
pub struct FreeRunning {
    /// Ticks per second of every pod.
    pub rate: f64,
    /// The command that starts a pod (`[seam, "node"]`).
    pub node_command: Vec<OsString>,
    /// The hosts the pods run on (one, unless set).
    pub hosts: crate::run::HostsPlan,
    /// Tick every pod at the same moment instead of staggering them (see `RunPlan::in_phase`).
    pub in_phase: bool,
}

/// Runs the scene at `scene_path` as free-running pods over `transport` with the proxy mode and
/// replication interval of `settings` (its other knobs must be left at the scene's), and
/// compares what they report with a single-world run of the same ticks.
pub fn run_free_trial(
    scene_path: &Path,
    scene: &Scene,
    settings: &TrialSettings,
    transport: &str,
    free: &FreeRunning,
    run_id: &str,
) -> Result<TrialResult, String> {
    run_free_trial_on_hosts(scene_path, scene, settings, transport, free, run_id)
        .map(|(result, _)| result)
}

/// As [`run_free_trial`], also returning how the hosts were simulated when `free.hosts` puts
/// the pods on several.
pub fn run_free_trial_on_hosts(
    scene_path: &Path,
    scene: &Scene,
    settings: &TrialSettings,
    transport: &str,
    free: &FreeRunning,
    run_id: &str,
) -> Result<(TrialResult, Option<String>), String> {
    let proxy_mode = match settings.proxy_mode {
        seam_proxy::ProxyMode::Fixed => ProxyModeArg::Fixed,
        _ => ProxyModeArg::Kinematic,
    };
    let ticks = settings.ticks.unwrap_or(scene.ticks);
    let plan = RunPlan {
        scene: scene_path.to_owned(),
        transport: transport.to_owned(),
        rate: free.rate,
        ticks: Some(ticks),
        proxy_mode,
        authority: settings.authority,
        replication_interval: settings.replication_interval,
        coupling: settings.coupling,
        quantize: settings.quantize,
        keyframe_ticks: settings.keyframe_ticks,
        layers: 1,
        run_id: run_id.to_owned(),
        node_command: free.node_command.clone(),
        start_delay: Duration::from_millis(500),
        in_phase: free.in_phase,
        hosts: free.hosts.clone(),
    };
    let (report, nodes) = run::run_pods(&plan, &AtomicBool::new(false), |_| {})?;

    let mut reference = Pod::new(
        scene,
        &Part::Reference,
        &PodSettings {
            proxy_mode: settings.proxy_mode,
            authority: settings.authority.mode(),
            replication_interval: settings.replication_interval,
            coupling: settings.coupling,
            ..PodSettings::new(
                format!("local?prefix=seam_free_{}_{run_id}_", std::process::id()),
                run_id,
            )
        },
    )
    .map_err(|e| format!("reference: {e}"))?;
    for _ in 0..ticks {
        reference.tick().map_err(|e| format!("reference: {e}"))?;
    }

    let mut accuracy = Accuracy::default();
    let truth: IdMap<EntityId, [f32; 3]> = reference.simulated_positions().into_iter().collect();
    let (mut squares, mut samples) = (0.0f64, 0u64);
    let mut owners: IdMap<EntityId, u32> = IdMap::default();
    for node in &nodes {
        for (id, position) in &node.final_positions {
            *owners.entry(*id).or_default() += 1;
            if let Some(t) = truth.get(id) {
                let error = (0..3)
                    .map(|k| f64::from(position[k] - t[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                squares += error * error;
                samples += 1;
                accuracy.position_max_m = accuracy.position_max_m.max(error);
            }
        }
    }
    accuracy.position_rms_m = (squares / samples.max(1) as f64).sqrt();
    accuracy.duplicate_owner_ticks = owners.values().filter(|&&n| n > 1).count() as u64;
    accuracy.missing_entity_ticks =
        truth.keys().filter(|id| !owners.contains_key(*id)).count() as u64;

    let mut split_hits: IdMap<(EntityId, EntityId), u64> = IdMap::default();
    for node in &nodes {
        for &(pair, tick) in &node.projectile_hits {
            let first = split_hits.entry(pair).or_insert(tick);
            *first = (*first).min(tick);
        }
    }
    let reference_hits = reference.projectile_hits();
    let (mut matched, mut offsets) = (0u64, 0u64);
    for (pair, tick) in reference_hits {
        if let Some(split_tick) = split_hits.get(pair) {
            matched += 1;
            offsets += tick.abs_diff(*split_tick);
        }
    }
    accuracy.hits_reference = reference_hits.len() as u64;
    accuracy.hits_split = split_hits.len() as u64;
    accuracy.hits_matched = matched;
    accuracy.hit_recall =
        (accuracy.hits_reference > 0).then(|| matched as f64 / accuracy.hits_reference as f64);
    accuracy.hit_precision =
        (accuracy.hits_split > 0).then(|| matched as f64 / accuracy.hits_split as f64);
    accuracy.hit_tick_offset_mean = if matched > 0 {
        offsets as f64 / matched as f64
    } else {
        0.0
    };
    accuracy.handoffs = report.totals.cluster.handoffs_in;

    let ran = report
        .pods
        .iter()
        .map(|p| p.ticks)
        .max()
        .unwrap_or(1)
        .max(1) as f64;
    let mut p50s: Vec<u64> = report.pods.iter().map(|p| p.tick_time.p50_ns).collect();
    p50s.sort_unstable();
    let bytes = |f: fn(&seam_proxy::ClusterStats) -> u64| {
        report.pods.iter().map(|p| f(&p.cluster_stats)).sum::<u64>() as f64 / ran
    };
    let ops = &report.ops;
    let simulated_as = report.hosts.as_ref().map(|h| h.simulated_as.clone());
    let result = TrialResult {
        scene: scene.name.clone(),
        transport: report.transport.clone(),
        position_basis: "final tick",
        settings: TrialSettings {
            ticks: Some(ticks),
            ..*settings
        },
        ticks,
        accuracy,
        cost: Cost {
            tick_p50_us: p50s.get(p50s.len() / 2).copied().unwrap_or(0) as f64 / 1e3,
            tick_sum_p50_us: p50s.iter().sum::<u64>() as f64 / 1e3,
            tick_p99_us: report
                .pods
                .iter()
                .map(|p| p.tick_time.p99_ns)
                .max()
                .unwrap_or(0) as f64
                / 1e3,
            replication_bytes_per_tick: bytes(|s| s.replication_bytes),
            events_bytes_per_tick: bytes(|s| s.events_bytes),
            bytes_per_state: {
                let mut stats = seam_proxy::ClusterStats::default();
                for pod in &report.pods {
                    stats += &pod.cluster_stats;
                }
                super::per_state(&stats)
            },
            proxies_mean: report.pods.iter().map(|p| p.proxies_peak as f64).sum(),
            ops: ops.ops,
            op_delay_p50_ticks: ops.ticks.p50,
            op_delay_max_ticks: ops.ticks.max,
            reference_tick_p50_us: 0.0,
            op_whole_p50_us: ops.whole.p50_ns as f64 / 1e3,
            op_whole_p99_us: ops.whole.p99_ns as f64 / 1e3,
            op_transport_p50_us: ops.transport.p50_ns as f64 / 1e3,
        },
    };
    Ok((result, simulated_as))
}
