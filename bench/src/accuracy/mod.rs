//! Accuracy against a single-world reference, and what it costs.
//!
//! A **trial** runs a scene twice side by side in this process, tick for tick: as one world
//! owning every entity (the reference, [`Part::Reference`]) and split over its clusters in
//! lock-step on the in-process transport, so both runs are deterministic and any difference
//! is the split's — proxies, routing delay, hand-offs. After every tick it compares them
//! ([`Comparison`]) and at the end reports accuracy and cost ([`TrialResult`]).
//!
//! A trial's knobs ([`TrialSettings`]) are the ones a user chooses between: proxy mode,
//! replication interval, observation spread (or proxies for everything), and for the scene's
//! projectiles their speed and CCD.

mod compare;
mod floor;
mod free;
mod one_world;

use crate::error::{BenchError, BenchResult, Context};
use crate::record::{EntityTable, PodRecorder};
use std::time::{Duration, Instant};

use seam_proxy::ProxyMode;
use seam_sim::wire::StateEncoding;
use serde::Serialize;

use crate::document::{Align::*, Document, Table};
use crate::latency::LatencyRecorder;
use crate::node::AuthorityArgs;
use crate::pod::{OpStages, Part, Pod, PodSettings};
use crate::scene::{Event, Scene};
pub use compare::{Accuracy, Comparison, ONSET_M, TRACKED_M, TRACKED_MPS};
pub use floor::{
    Basis, FLOOR_WORLDS, Floor, FloorRun, FloorWorld, PERTURBATION_M, beyond_floor, floor_words,
};
pub use free::{FreeRunning, run_free_trial, run_free_trial_on_hosts};
pub use one_world::{AgainstOneWorld, JudgedRun, judged_document};

/// How long a lock-step tick may wait for a neighbour's frame before the trial fails.
const LOCKSTEP_TIMEOUT: Duration = Duration::from_secs(10);

/// The knobs of one trial.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrialSettings {
    /// How neighbour entities are modelled.
    #[serde(serialize_with = "proxy_mode_name")]
    pub proxy_mode: ProxyMode,
    /// Which hand-offs the clusters make besides the scene's.
    pub authority: AuthorityArgs,
    /// A replication frame every this many ticks.
    pub replication_interval: u64,
    /// Whether contacts push across the seam (see `seam_proxy::ClusterConfig::coupling`).
    pub coupling: bool,
    /// Whether routed ops are exchanged before the step (see
    /// `seam_proxy::ClusterConfig::exchange`).
    pub exchange: bool,
    /// Quantized replication states (see `seam_sim::wire::StateEncoding`).
    pub quantize: bool,
    /// A keyframe at most every this many ticks (see `ClusterConfig::keyframe_ticks`).
    pub keyframe_ticks: u64,
    /// Observation spread of every cluster, m (`None`: the scene's); see `interest`.
    pub spread: Option<f32>,
    /// `false`: every cluster proxies every neighbour entity wherever it is (no interest
    /// management).
    pub interest: bool,
    /// Speed of the scene's projectiles, m/s (`None`: the scene's), along their direction.
    pub projectile_speed: Option<f32>,
    /// CCD on the scene's projectiles (`None`: the scene's).
    pub projectile_ccd: Option<bool>,
    /// Ticks (`None`: the scene's).
    pub ticks: Option<u64>,
}

fn proxy_mode_name<S: serde::Serializer>(mode: &ProxyMode, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(mode_name(*mode))
}

/// The name of a proxy mode in tables and CSV.
pub fn mode_name(mode: ProxyMode) -> &'static str {
    match mode {
        ProxyMode::Fixed => "fixed",
        ProxyMode::KinematicVelocityBased => "kinematic",
        ProxyMode::Custom => "custom",
    }
}

impl Default for TrialSettings {
    fn default() -> Self {
        Self {
            proxy_mode: ProxyMode::Fixed,
            authority: AuthorityArgs::default(),
            replication_interval: 1,
            coupling: true,
            exchange: true,
            quantize: false,
            keyframe_ticks: seam_proxy::DEFAULT_KEYFRAME_TICKS,
            spread: None,
            interest: true,
            projectile_speed: None,
            projectile_ccd: None,
            ticks: None,
        }
    }
}

impl TrialSettings {
    /// The scene as this trial runs it.
    pub fn apply(&self, mut scene: Scene) -> Scene {
        for cluster in &mut scene.clusters {
            if let Some(spread) = self.spread {
                cluster.spread = spread;
            }
            if !self.interest {
                // Far beyond any scene: every neighbour entity is modelled.
                cluster.spread = 1.0e6;
            }
        }
        for event in &mut scene.events {
            if let Event::Projectile { velocity, ccd, .. } = event {
                if let Some(speed) = self.projectile_speed {
                    let length = velocity.iter().map(|c| c * c).sum::<f32>().sqrt();
                    if length > 0.0 {
                        *velocity = velocity.map(|c| c / length * speed);
                    }
                }
                if let Some(on) = self.projectile_ccd {
                    *ccd = on;
                }
            }
        }
        if let Some(speed) = self.projectile_speed {
            scene.max_speed = scene.max_speed.max(speed * 1.01);
        }
        if let Some(ticks) = self.ticks {
            scene.ticks = ticks;
        }
        scene
    }
}

/// What it cost.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Cost {
    /// Median tick time of the split clusters, µs (the median of their medians).
    pub tick_p50_us: f64,
    /// Worst p99 tick time of a split cluster, µs.
    pub tick_p99_us: f64,
    /// The sum over the split clusters of each one's median tick time, µs: the CPU one tick
    /// of the split world takes (against `reference_tick_p50_us` for the single world).
    pub tick_sum_p50_us: f64,
    /// Replication bytes published per tick, all clusters.
    pub replication_bytes_per_tick: f64,
    /// Physics-events bytes published per tick, all clusters.
    pub events_bytes_per_tick: f64,
    /// Replication bytes per state published (frame headers included).
    pub bytes_per_state: f64,
    /// Proxies modelled, all clusters: the mean over ticks (lock-step), or the sum of each
    /// pod's peak (free-running pods).
    pub proxies_mean: f64,
    /// Routed ops applied.
    pub ops: u64,
    /// Routed ops sent (by their issuers; one forwarded by a former owner counts once), so
    /// that `ops_routed − ops` is what never got applied.
    pub ops_routed: u64,
    /// Median delay of a routed op, ticks (issuer's write → owner's apply).
    pub op_delay_p50_ticks: u64,
    /// Largest delay of a routed op, ticks.
    pub op_delay_max_ticks: u64,
    /// Tick time of the reference world, median, µs.
    pub reference_tick_p50_us: f64,
    /// Whole routed-op latency (issued → applied), p50, µs.
    pub op_whole_p50_us: f64,
    /// Whole routed-op latency, p99, µs.
    pub op_whole_p99_us: f64,
    /// Transport stage of routed ops (published → received), p50, µs.
    pub op_transport_p50_us: f64,
}

/// One trial's settings, accuracy and cost.
#[derive(Debug, Clone, Serialize)]
pub struct TrialResult {
    /// The scene.
    pub scene: String,
    /// `lockstep` (clusters in this process, in lock-step on the in-process transport) or the
    /// transport URL of free-running pods (`shm`, `redis://…`).
    pub transport: String,
    /// What the position error is taken over: `every tick` (lock-step) or `final tick`
    /// (free-running pods report where their bodies ended).
    pub position_basis: &'static str,
    /// The knobs.
    pub settings: TrialSettings,
    /// Ticks run.
    pub ticks: u64,
    /// Accuracy against the reference.
    pub accuracy: Accuracy,
    /// The noise floor: the farthest figures of [`FLOOR_WORLDS`] single worlds, bodies
    /// inserted in reverse order and every dynamic one moved [`PERTURBATION_M`], judged
    /// against the reference with the same metrics (see [`FloorRun`]). An error at the floor
    /// is the scene's chaos, not the split's.
    pub floor: Accuracy,
    /// Each of those worlds' position error and onset.
    pub floor_worlds: Vec<FloorWorld>,
    /// Cost.
    pub cost: Cost,
}

/// Runs `scene` split and as a reference, tick for tick, and compares them.
/// With `trace`, prints that entity's every tick (see [`Comparison::trace`]).
pub fn run_trial(
    scene: &Scene,
    settings: &TrialSettings,
    trace: Option<&str>,
) -> BenchResult<TrialResult> {
    run_recorded_trial(scene, settings, trace, None)
}

/// The run name every lock-step trial derives its cluster and entity ids from. Ids order
/// some sums (impulses settled per body, ties between clusters), so ids drawn afresh per run
/// would make two runs of one trial differ at round-off and then, on a chaotic scene, by
/// centimetres; one name for all makes a trial reproducible figure for figure. Trials stay
/// apart on the transport by their prefix.
const TRIAL_RUN: &str = "seam-trial";

/// Trials begun in this process, so each gets a transport prefix of its own.
static TRIALS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// The settings of a lock-step trial's pods on `transport`.
fn trial_pod_settings(settings: &TrialSettings, transport: String) -> PodSettings {
    PodSettings {
        proxy_mode: settings.proxy_mode,
        authority: settings.authority.mode(),
        replication_interval: settings.replication_interval,
        coupling: settings.coupling,
        exchange: settings.exchange,
        state_encoding: if settings.quantize {
            StateEncoding::Quantized
        } else {
            StateEncoding::Exact
        },
        keyframe_ticks: settings.keyframe_ticks,
        ..PodSettings::new(transport, TRIAL_RUN)
    }
}

/// A recorder of a lock-step trial of `scene` (the single world's stream included) into
/// `path`.
fn trial_recorder(scene: &Scene, path: &std::path::Path) -> BenchResult<PodRecorder> {
    let table = EntityTable::new(scene, TRIAL_RUN, scene.ticks, 0.0, "seam compare", true);
    Ok(PodRecorder::create(path, table)?)
}

/// One lock-step tick of every pod, in two halves (every pod's first half before any
/// second, so each has its neighbours' exchanged ops before it steps); returns each pod's
/// time in its two halves, ns.
fn tick_lockstep(pods: &mut [Pod]) -> BenchResult<Vec<u64>> {
    let mut took = Vec::with_capacity(pods.len());
    for pod in pods.iter_mut() {
        let begun = Instant::now();
        pod.begin_lockstep(LOCKSTEP_TIMEOUT).context(pod.name())?;
        took.push(begun.elapsed().as_nanos() as u64);
    }
    for (pod, took) in pods.iter_mut().zip(&mut took) {
        let begun = Instant::now();
        pod.finish_lockstep(LOCKSTEP_TIMEOUT).context(pod.name())?;
        *took += begun.elapsed().as_nanos() as u64;
    }
    Ok(took)
}

/// `accuracy` with the hand-offs the `pods` took with no proxy of the body counted in.
fn without_proxy(mut accuracy: Accuracy, pods: &[Pod]) -> Accuracy {
    accuracy.handoffs_without_proxy = pods
        .iter()
        .map(|pod| pod.cluster().stats().handoffs_in_without_proxy)
        .sum();
    accuracy
}

/// The pods' op stages and counters, summed.
fn merged(pods: &[Pod]) -> (OpStages, seam_proxy::ClusterStats) {
    let mut ops = OpStages::default();
    let mut stats = seam_proxy::ClusterStats::default();
    for pod in pods {
        ops.merge(pod.op_stages());
        stats += &pod.cluster().stats();
    }
    (ops, stats)
}

/// As [`run_trial`], also recording every cluster's ticks and the single world's into
/// `record` (see [`crate::record`]).
pub fn run_recorded_trial(
    scene: &Scene,
    settings: &TrialSettings,
    trace: Option<&str>,
    record: Option<&std::path::Path>,
) -> BenchResult<TrialResult> {
    let scene = settings.apply(scene.clone());
    let pod_settings = |transport: String| trial_pod_settings(settings, transport);
    let trial = TRIALS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let prefix = format!("seam_trial_{}_{trial}_", std::process::id());
    let mut reference = Pod::new(
        &scene,
        &Part::Reference,
        &pod_settings(format!("local?prefix={prefix}ref_")),
    )
    .context("reference")?;
    let split_url = format!("local?prefix={prefix}split_");
    let mut pods = scene
        .clusters
        .iter()
        .map(|c| {
            Pod::new(
                &scene,
                &Part::Cluster(c.name.clone()),
                &pod_settings(split_url.clone()),
            )
            .context(&c.name)
        })
        .collect::<Result<Vec<_>, _>>()?;

    let mut floor = FloorRun::start(
        &scene,
        &reference,
        &pod_settings(format!("local?prefix={prefix}floor_")),
        Basis::EveryTick,
    )?;
    let mut comparison = Comparison::new(&scene, &reference);
    if let Some(name) = trace {
        comparison.trace(&reference, name)?;
    }
    let mut tick_times: Vec<LatencyRecorder> = pods.iter().map(|_| Default::default()).collect();
    let mut reference_time = LatencyRecorder::default();
    let mut proxies_sum = 0u64;
    let mut recorder = match record {
        Some(path) => Some(trial_recorder(&scene, path)?),
        None => None,
    };
    let recording = |e: crate::record::RecordError| BenchError::from(e).within("recording");
    for _ in 0..scene.ticks {
        let begun = Instant::now();
        reference.tick().context("reference")?;
        let took = begun.elapsed().as_nanos() as u64;
        reference_time.record(took);
        if let Some(recorder) = &mut recorder {
            recorder.observe(&reference, took).map_err(recording)?;
        }
        floor.observe(&reference)?;
        let took = tick_lockstep(&mut pods)?;
        for ((pod, time), &took) in pods.iter_mut().zip(&mut tick_times).zip(&took) {
            time.record(took);
            proxies_sum += pod.population().1 as u64;
            if let Some(recorder) = &mut recorder {
                recorder.observe(pod, took).map_err(recording)?;
            }
        }
        comparison.observe(&reference, &pods);
    }
    if let Some(recorder) = recorder {
        recorder.finish().map_err(recording)?;
    }
    let floor = floor.finish(&reference);
    Ok(TrialResult {
        scene: scene.name.clone(),
        transport: "lockstep".to_owned(),
        position_basis: "every tick",
        settings: *settings,
        ticks: scene.ticks,
        accuracy: without_proxy(comparison.finish(|id| reference.entity_name(id)), &pods),
        floor: floor.farthest,
        floor_worlds: floor.worlds,
        cost: lockstep_cost(
            &pods,
            &tick_times,
            &reference_time,
            proxies_sum,
            scene.ticks,
        ),
    })
}

/// What a lock-step trial of `ticks` ticks cost: the pods' tick times and counters, the
/// single world's tick time, the proxies summed over ticks.
fn lockstep_cost(
    pods: &[Pod],
    tick_times: &[LatencyRecorder],
    reference_time: &LatencyRecorder,
    proxies_sum: u64,
    ticks: u64,
) -> Cost {
    let ticks = ticks.max(1);
    let (ops, stats) = merged(pods);
    let mut p50s: Vec<u64> = tick_times.iter().map(|t| t.summary().p50_ns).collect();
    p50s.sort_unstable();
    let ops = ops.summary();
    Cost {
        tick_p50_us: p50s.get(p50s.len() / 2).copied().unwrap_or(0) as f64 / 1e3,
        tick_sum_p50_us: p50s.iter().sum::<u64>() as f64 / 1e3,
        tick_p99_us: tick_times
            .iter()
            .map(|t| t.summary().p99_ns)
            .max()
            .unwrap_or(0) as f64
            / 1e3,
        replication_bytes_per_tick: stats.replication_bytes as f64 / ticks as f64,
        events_bytes_per_tick: stats.events_bytes as f64 / ticks as f64,
        bytes_per_state: per_state(&stats),
        proxies_mean: proxies_sum as f64 / ticks as f64,
        ops: ops.ops,
        ops_routed: stats.ops_routed,
        op_delay_p50_ticks: ops.ticks.p50,
        op_delay_max_ticks: ops.ticks.max,
        reference_tick_p50_us: reference_time.summary().p50_ns as f64 / 1e3,
        op_whole_p50_us: ops.whole.p50_ns as f64 / 1e3,
        op_whole_p99_us: ops.whole.p99_ns as f64 / 1e3,
        op_transport_p50_us: ops.transport.p50_ns as f64 / 1e3,
    }
}

/// Replication bytes per state published (0 when none was).
pub(crate) fn per_state(stats: &seam_proxy::ClusterStats) -> f64 {
    if stats.states_replicated == 0 {
        0.0
    } else {
        stats.replication_bytes as f64 / stats.states_replicated as f64
    }
}

pub(super) fn ratio(value: Option<f64>) -> String {
    value.map_or("-".to_owned(), |v| format!("{v:.3}"))
}

/// What `seam compare` reports: each trial's accuracy and cost in words, then one table with
/// a row per trial (as docs/accuracy.md quotes it with `--markdown`).
pub fn document(results: &[TrialResult]) -> Document {
    let mut doc = Document::new();
    for r in results {
        doc.line(trial_text(r));
        doc.line("");
    }
    doc.table(summary(results));
    doc
}

/// A trial's result in words.
fn trial_text(r: &TrialResult) -> String {
    let (s, a, c) = (&r.settings, &r.accuracy, &r.cost);
    format!(
        "seam compare: {} split ({}) against one world, {} ticks\n\
         settings: {} proxies, contact coupling {}, ops {}, {} authority, replication every {} tick(s) \
         ({} states), spread {}, projectiles {}, CCD {}\n\n\
         accuracy\n\
         \x20 position error       RMS {:.4} m, max {:.4} m (over {}){}\n\
         {}\
         \x20 orientation error    RMS {:.3}°, max {:.3}°\n\
         \x20 projectile hits      {} in the single world, {} split, {} matched: recall {}, \
         precision {}, mean tick offset {:.2}\n\
         \x20 momentum error       max {:.4} kg·m/s, mean {:.5} of Σm|v| (the single world's own \
         drift: {:.5})\n\
         {}\
         \x20 ownership            {} body-ticks with two owners, {} lost, {} in transit \
         (hand-off read next tick); {} bodies escaped (fell through or flew off where the \
         single world's did not)\n\n\
         cost (split run)\n\
         \x20 tick time            p50 {:.1} µs (median cluster), p99 {:.1} µs (worst), p50s \
         summed over clusters {:.1} µs; one world p50 {:.1} µs\n\
         \x20 bytes per tick       {:.0} replication, {:.0} physics events (all clusters); {:.1} bytes per \
         replicated state\n\
         \x20 proxies              {:.1} on average\n\
         \x20 routed ops           {}, delay p50 {} tick(s), max {}; whole p50 {:.1} µs, p99 {:.1} µs, \
         transport p50 {:.1} µs\n",
        r.scene,
        r.transport,
        r.ticks,
        mode_name(s.proxy_mode),
        if s.coupling { "on" } else { "off" },
        if s.exchange {
            "exchanged before the step"
        } else {
            "after the step"
        },
        s.authority.label(),
        s.replication_interval,
        if s.quantize { "quantized" } else { "exact" },
        if s.interest {
            s.spread
                .map_or("as in the scene".to_owned(), |v| format!("{v} m"))
        } else {
            "everything".to_owned()
        },
        s.projectile_speed
            .map_or("as in the scene".to_owned(), |v| format!("{v} m/s")),
        s.projectile_ccd
            .map_or("as in the scene", |v| if v { "on" } else { "off" }),
        a.position_rms_m,
        a.position_max_m,
        r.position_basis,
        a.worst_body
            .as_ref()
            .map_or(String::new(), |(name, tick)| format!(
                ", largest: {name} at tick {tick}"
            )),
        floor_text(r),
        a.rotation_rms_deg,
        a.rotation_max_deg,
        a.hits_reference,
        a.hits_split,
        a.hits_matched,
        ratio(a.hit_recall),
        ratio(a.hit_precision),
        a.hit_tick_offset_mean,
        a.momentum_error_max,
        a.momentum_error_rel,
        a.momentum_drift_rel,
        handoff_text(r),
        a.duplicate_owner_ticks,
        a.missing_entity_ticks,
        a.in_transit_ticks,
        a.escaped_bodies,
        c.tick_p50_us,
        c.tick_p99_us,
        c.tick_sum_p50_us,
        c.reference_tick_p50_us,
        c.replication_bytes_per_tick,
        c.events_bytes_per_tick,
        c.bytes_per_state,
        c.proxies_mean,
        c.ops,
        c.op_delay_p50_ticks,
        c.op_delay_max_ticks,
        c.op_whole_p50_us,
        c.op_whole_p99_us,
        c.op_transport_p50_us,
    )
}

/// The hand-offs line of [`trial_text`].
fn handoff_text(r: &TrialResult) -> String {
    let a = &r.accuracy;
    format!(
        "\x20 hand-offs            {} ({} of bodies already off track or near one that is, not \
         judged; {} to a cluster with no proxy of the body): largest jump {:.5} m, {:.5} m/s{}; \
         a tracked body's largest one-tick departure without a flip {:.5} m, {:.5} m/s (the \
         floor's: {:.5} m, {:.5} m/s)\n",
        a.handoffs,
        a.handoffs_untracked,
        a.handoffs_without_proxy,
        a.handoff_jump_position_m,
        a.handoff_jump_velocity_mps,
        a.worst_handoff
            .as_ref()
            .map_or(String::new(), |(name, tick)| format!(
                " ({name} at tick {tick})"
            )),
        a.step_jump_position_m,
        a.step_jump_velocity_mps,
        r.floor.step_jump_position_m,
        r.floor.step_jump_velocity_mps,
    )
}

/// The noise floor's lines of a trial's text: the floor, the onsets, and whether the trial is
/// at the floor.
fn floor_text(r: &TrialResult) -> String {
    format!(
        "\x20 noise floor          RMS {:.4} m, max {:.4} m: {}\n\
         \x20 onset                {} (the floor's {}): first tick a body is {} cm off one world\n\
         \x20 against the floor    {}\n",
        r.floor.position_rms_m,
        r.floor.position_max_m,
        floor_words(&r.floor_worlds),
        onset_text(r.accuracy.onset_tick, r.position_basis),
        onset_text(r.floor.onset_tick, "every tick"),
        ONSET_M * 100.0,
        floor_verdict(r),
    )
}

/// Whether a trial is at its noise floor (see [`beyond_floor`]), in words. A free-running
/// run's onset is not known, so only its final positions are judged.
fn floor_verdict(r: &TrialResult) -> String {
    let misses = beyond_floor(&r.accuracy, &r.floor);
    if misses.is_empty() {
        "at the floor (RMS ≤ max(1.5 × floor, 1 cm), max ≤ max(1.5 × floor, 5 cm), onset ≥ \
         0.8 × floor's, hand-off jump ≤ max(1.5 × floor's one-tick departure, 1 cm and 0.05 m/s))"
            .to_owned()
    } else {
        format!("beyond it: {}", misses.join("; "))
    }
}

/// An onset tick in words: `never`, or not known for a run judged by its final tick.
fn onset_text(onset: Option<u64>, basis: &str) -> String {
    match onset {
        Some(tick) => format!("tick {tick}"),
        None if basis == "every tick" => "never".to_owned(),
        None => "not known (final tick only)".to_owned(),
    }
}

/// An onset tick in a table cell.
fn onset_cell(onset: Option<u64>, basis: &str) -> String {
    match onset {
        Some(tick) => tick.to_string(),
        None if basis == "every tick" => "never".to_owned(),
        None => "-".to_owned(),
    }
}

/// Trial results as one table, a row each.
fn summary(results: &[TrialResult]) -> Table {
    let mut table = Table::new(&[
        ("scene", Left),
        ("proxies", Left),
        ("authority", Left),
        ("every", Right),
        ("spread", Left),
        ("position RMS m", Right),
        ("max m", Right),
        ("floor RMS, max m", Right),
        ("onset (floor's)", Right),
        ("escaped", Right),
        ("hit recall", Right),
        ("precision", Right),
        ("momentum error (drift)", Right),
        ("hand-offs (judged)", Right),
        ("largest jump m, m/s", Right),
        ("CPU/tick summed ms", Right),
        ("one world ms", Right),
        ("kB/tick", Right),
        ("B/state", Right),
    ]);
    for r in results {
        let (s, a, c) = (&r.settings, &r.accuracy, &r.cost);
        table.row(vec![
            format!("`{}`", r.scene),
            format!(
                "{}{}{}{}",
                mode_name(s.proxy_mode),
                if s.coupling { "" } else { ", uncoupled" },
                if s.exchange {
                    ""
                } else {
                    ", ops after the step"
                },
                if s.quantize { ", quantized" } else { "" }
            ),
            s.authority.label(),
            s.replication_interval.to_string(),
            if s.interest {
                s.spread.map_or("scene's".to_owned(), |v| format!("{v} m"))
            } else {
                "everything".to_owned()
            },
            format!("{:.4}", a.position_rms_m),
            format!("{:.3}", a.position_max_m),
            format!(
                "{:.4}, {:.3}",
                r.floor.position_rms_m, r.floor.position_max_m
            ),
            format!(
                "{} ({})",
                onset_cell(a.onset_tick, r.position_basis),
                onset_cell(r.floor.onset_tick, "every tick")
            ),
            a.escaped_bodies.to_string(),
            ratio(a.hit_recall),
            ratio(a.hit_precision),
            format!("{:.4} ({:.4})", a.momentum_error_rel, a.momentum_drift_rel),
            format!("{} ({})", a.handoffs, a.handoffs - a.handoffs_untracked),
            format!(
                "{:.4}, {:.3}",
                a.handoff_jump_position_m, a.handoff_jump_velocity_mps
            ),
            format!("{:.2}", c.tick_sum_p50_us / 1e3),
            format!("{:.2}", c.reference_tick_p50_us / 1e3),
            format!(
                "{:.1}",
                (c.replication_bytes_per_tick + c.events_bytes_per_tick) / 1e3
            ),
            format!("{:.1}", c.bytes_per_state),
        ]);
    }
    table
}
