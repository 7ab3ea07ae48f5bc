//! The transport axis: a scene's clusters as free-running pod processes (`seam run`) on shm or
//! Redis, compared with a single-world reference run in this process.
//!
//! Free-running pods are not deterministic (what a pod sees depends on when frames arrive), so
//! only what they report at the end is compared: projectile hits (pairs and ticks) and where
//! every dynamic body ended. Cost comes from the run's report: tick times, bytes, proxies, and
//! routed-op latency stage by stage, which is what the transport changes.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use seam_sim::wire::{EntityId, IdMap};

use super::{Accuracy, Basis, Cost, Floor, FloorRun, TrialResult, TrialSettings};
use crate::error::{BenchResult, Context};
use crate::node::{NodeReport, ProxyModeArg};
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
    /// Stagger the pods over the period instead of ticking them in phase (see
    /// `RunPlan::stagger`).
    pub stagger: bool,
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
) -> BenchResult<TrialResult> {
    run_free_trial_on_hosts(scene_path, scene, settings, transport, free, run_id)
        .map(|(result, _)| result)
}

/// The `seam run` plan of a free-running trial of `ticks` ticks.
fn free_run_plan(
    scene_path: &Path,
    settings: &TrialSettings,
    transport: &str,
    free: &FreeRunning,
    run_id: &str,
    ticks: u64,
) -> RunPlan {
    let proxy_mode = match settings.proxy_mode {
        seam_proxy::ProxyMode::Fixed => ProxyModeArg::Fixed,
        _ => ProxyModeArg::Kinematic,
    };
    RunPlan {
        rate: free.rate,
        ticks: Some(ticks),
        proxy_mode,
        authority: settings.authority,
        replication_interval: settings.replication_interval,
        coupling: settings.coupling,
        exchange: settings.exchange,
        quantize: settings.quantize,
        keyframe_ticks: settings.keyframe_ticks,
        run_id: run_id.to_owned(),
        node_command: free.node_command.clone(),
        start_delay: Duration::from_millis(500),
        stagger: free.stagger,
        hosts: free.hosts.clone(),
        track_flips: true,
        ..RunPlan::new(scene_path, transport)
    }
}

/// Each pod's final positions against the reference's (`truth`): errors, and bodies owned
/// twice or by nobody.
fn judge_final_positions(
    nodes: &[NodeReport],
    truth: &IdMap<EntityId, [f32; 3]>,
    accuracy: &mut Accuracy,
) {
    let mut owners: IdMap<EntityId, u32> = IdMap::default();
    let mut ended = Vec::new();
    for node in nodes {
        for &(id, position) in &node.final_positions {
            *owners.entry(id).or_default() += 1;
            ended.push((id, position));
        }
    }
    (accuracy.position_rms_m, accuracy.position_max_m) = super::floor::final_errors(&ended, truth);
    accuracy.duplicate_owner_ticks = owners.values().filter(|&&n| n > 1).count() as u64;
    accuracy.missing_entity_ticks =
        truth.keys().filter(|id| !owners.contains_key(*id)).count() as u64;
}

/// The body that ended farthest from its single-world copy (`truth`), if any is off at all.
fn worst_ended(nodes: &[NodeReport], truth: &IdMap<EntityId, [f32; 3]>) -> Option<EntityId> {
    let mut worst: Option<(EntityId, f32)> = None;
    for &(id, position) in nodes.iter().flat_map(|n| &n.final_positions) {
        let Some(t) = truth.get(&id) else { continue };
        let error = (0..3).map(|k| (position[k] - t[k]).powi(2)).sum::<f32>();
        if error > 0.0 && worst.is_none_or(|(_, w)| error > w) {
            worst = Some((id, error));
        }
    }
    worst.map(|(id, _)| id)
}

/// The pods' projectile hits against the reference's: recall, precision, tick offsets.
fn judge_hits(
    nodes: &[NodeReport],
    reference_hits: &BTreeMap<(EntityId, EntityId), u64>,
    accuracy: &mut Accuracy,
) {
    let mut split_hits: IdMap<(EntityId, EntityId), u64> = IdMap::default();
    for node in nodes {
        for &(pair, tick) in &node.projectile_hits {
            let first = split_hits.entry(pair).or_insert(tick);
            *first = (*first).min(tick);
        }
    }
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
) -> BenchResult<(TrialResult, Option<String>)> {
    let ticks = settings.ticks.unwrap_or(scene.ticks);
    let plan = free_run_plan(scene_path, settings, transport, free, run_id, ticks);
    let (report, nodes) = run::run_pods(&plan, &AtomicBool::new(false), |_| {})?;
    let (accuracy, floor) = judge_pods(scene, settings, run_id, ticks, &nodes)?;

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
        floor: floor.farthest,
        floor_worlds: floor.worlds,
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
            ops_routed: report.totals.cluster.ops_routed,
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

/// What free-running pods' reports (`nodes`, after `ticks` ticks of `scene` with `settings`)
/// show against one world run here for as many ticks, and that world's noise floor: where
/// every body ended, projectile hits, hand-offs, bodies owned twice or by nobody.
pub(super) fn judge_pods(
    scene: &Scene,
    settings: &TrialSettings,
    run_id: &str,
    ticks: u64,
    nodes: &[NodeReport],
) -> BenchResult<(Accuracy, Floor)> {
    let (reference, floor, truth_at) = run_reference(scene, settings, run_id, ticks, nodes)?;
    let mut accuracy = Accuracy::default();
    let truth: IdMap<EntityId, [f32; 3]> = reference.simulated_positions().into_iter().collect();
    judge_final_positions(nodes, &truth, &mut accuracy);
    accuracy.worst_body = worst_ended(nodes, &truth).map(|id| (reference.entity_name(id), ticks));
    judge_hits(nodes, reference.projectile_hits(), &mut accuracy);
    judge_flips(nodes, &truth_at, &mut accuracy);
    Ok((accuracy, floor.finish(&reference)))
}

/// The single world of a free-running trial, run for `ticks` beside its noise floor, with the
/// states its pods' recorded flips are judged against.
fn run_reference(
    scene: &Scene,
    settings: &TrialSettings,
    run_id: &str,
    ticks: u64,
    nodes: &[NodeReport],
) -> BenchResult<(Pod, FloorRun, TruthAt)> {
    let reference_settings = |part: &str| PodSettings {
        proxy_mode: settings.proxy_mode,
        authority: settings.authority.mode(),
        replication_interval: settings.replication_interval,
        coupling: settings.coupling,
        exchange: settings.exchange,
        ..PodSettings::new(
            format!(
                "local?prefix=seam_free_{}_{run_id}_{part}_",
                std::process::id()
            ),
            run_id,
        )
    };
    let mut reference =
        Pod::new(scene, &Part::Reference, &reference_settings("ref")).context("reference")?;
    let mut floor = FloorRun::start(
        scene,
        &reference,
        &reference_settings("floor"),
        Basis::FinalTick,
    )?;
    // The reference states each recorded flip is judged against: (entity, tick).
    let mut wanted: std::collections::HashMap<u64, Vec<EntityId>> = Default::default();
    for flip in nodes.iter().flat_map(|n| &n.flips) {
        wanted.entry(flip.tick).or_default().push(flip.entity);
    }
    let mut truth_at: TruthAt = Default::default();
    for _ in 0..ticks {
        reference.tick().context("reference")?;
        floor.observe(&reference)?;
        let sim = reference.cluster().sim();
        if let Some(ids) = wanted.get(&sim.tick()) {
            for &id in ids {
                if let Some(state) = sim.state(id) {
                    truth_at.insert((id, sim.tick()), (state.position, state.linvel));
                }
            }
        }
    }
    Ok((reference, floor, truth_at))
}

/// The single world's position and velocity of a body at a tick.
type TruthAt = std::collections::HashMap<(EntityId, u64), ([f32; 3], [f32; 3])>;

/// Judges every flip the pods recorded as `seam compare` judges a hand-off: for a body that was
/// within [`super::TRACKED_M`] and [`super::TRACKED_MPS`] of its single-world copy when its old
/// owner last had it, how far its motion from that state to its new owner's first state
/// departs from the single world's over the same ticks (position and velocity). Bodies first owned with no owner before them
/// (spawned, or adopted from a pod whose records died with it) are not hand-offs; hand-offs
/// of bodies already off track, or gone from the single world, are counted as untracked.
/// Unlike `seam compare`, a flip is judged on the body alone: the pods record only the bodies
/// they hand, not where the bodies it may meet were, so a body handed as it meets one already
/// off track is judged too (free-running `ramp`: 0.36 m/s, where `seam compare` leaves that
/// flip out).
fn judge_flips(nodes: &[crate::node::NodeReport], truth_at: &TruthAt, accuracy: &mut Accuracy) {
    let mut gave: IdMap<EntityId, Vec<&crate::pod::FlipRecord>> = IdMap::default();
    for flip in nodes.iter().flat_map(|n| &n.flips).filter(|f| !f.took) {
        gave.entry(flip.entity).or_default().push(flip);
    }
    let distance = |a: [f32; 3], b: [f32; 3]| {
        (0..3)
            .map(|k| f64::from(a[k] - b[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let sub = |a: [f32; 3], b: [f32; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let (mut judged, mut untracked) = (0u64, 0u64);
    for took in nodes.iter().flat_map(|n| &n.flips).filter(|f| f.took) {
        let before = gave.get(&took.entity).and_then(|records| {
            records
                .iter()
                .filter(|g| g.tick < took.tick)
                .max_by_key(|g| g.tick)
        });
        // No earlier owner recorded giving it up: a body spawned here, or adopted from a pod
        // that died (its record died with it) — not a hand-off.
        let Some(before) = before else {
            continue;
        };
        let Some(truth_after) = truth_at.get(&(took.entity, took.tick)) else {
            untracked += 1;
            continue;
        };
        let Some(truth_before) = truth_at.get(&(before.entity, before.tick)) else {
            untracked += 1;
            continue;
        };
        if distance(before.position, truth_before.0) > super::TRACKED_M
            || distance(before.linvel, truth_before.1) > super::TRACKED_MPS
        {
            untracked += 1;
            continue;
        }
        judged += 1;
        let moved = sub(took.position, before.position);
        let moved_truth = sub(truth_after.0, truth_before.0);
        let sped = sub(took.linvel, before.linvel);
        let sped_truth = sub(truth_after.1, truth_before.1);
        accuracy.handoff_jump_position_m = accuracy
            .handoff_jump_position_m
            .max(distance(moved, moved_truth));
        accuracy.handoff_jump_velocity_mps = accuracy
            .handoff_jump_velocity_mps
            .max(distance(sped, sped_truth));
    }
    accuracy.handoffs = judged + untracked;
    accuracy.handoffs_untracked = untracked;
}
