//! `seam node`: one cluster pod running its part of a scene.
//!
//! The pod ticks on a [`seam_proxy::Schedule`] (60 Hz unless told otherwise, or as fast as it
//! can with rate 0): between ticks it sleeps on its transport's wake-up, taking frames off the
//! transport as they arrive, so an idle pod uses no CPU and "received" stamps mean arrival.
//! Pods started by `seam run` share a start time on the host's monotonic clock, so their tick
//! `k` falls at the same moment; a pod restarted with `--rejoin` joins at the tick the schedule
//! is at. SIGINT or SIGTERM ends the run after the current tick, and the pod still reports.
//! The last half second of a run (`seam_proxy::DRAIN_S`) starts no policy hand-offs, so that
//! every hand-off under way is taken before the pods stop.
//!
//! Output: JSON lines on stdout, a [`NodeLine::Progress`] four times a second and one
//! [`NodeLine::Report`] at the end (also written to `--metrics FILE` if given). On stderr,
//! through `tracing` (`RUST_LOG`, see [`crate::console`]): the pod's start and end, what the
//! library logs (neighbours taken for dead and back, Redis outages), and unless `--quiet` a
//! human progress line four times a second.

mod phases;
mod report;

use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use seam_proxy::{
    AuthorityMode, GroupSettings, ProxyMode, Schedule, SpatialSettings, monotonic_ns,
};
use seam_sim::wire::StateEncoding;

use crate::error::{BenchError, BenchResult, Context};
use crate::latency::LatencyRecorder;
use crate::ledger::LedgerFile;
use crate::pod::{Part, Pod, PodSettings};
use crate::record::{EntityTable, PodRecorder};
pub use phases::{CENSUS_EVERY, CensusMean, PhaseTally, PhaseTime};
pub use report::{NodeLine, NodeProgress, NodeReport, TransportCounts};

/// How neighbour entities are modelled, as a command-line value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ProxyModeArg {
    /// Fixed bodies set to each replicated pose.
    Fixed,
    /// Kinematic bodies moving with the velocity that reaches the next replicated pose.
    Kinematic,
}

impl From<ProxyModeArg> for ProxyMode {
    fn from(mode: ProxyModeArg) -> Self {
        match mode {
            ProxyModeArg::Fixed => ProxyMode::Fixed,
            ProxyModeArg::Kinematic => ProxyMode::KinematicVelocityBased,
        }
    }
}

/// Which hand-offs pods make, as a command-line value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AuthorityArg {
    /// Authority follows entities: an entity past a seam by the margin is handed to the
    /// cluster whose region it is in (`seam_proxy::Spatial`), besides the scene's hand-offs.
    Spatial,
    /// Only the scene's hand-off events move entities.
    Scripted,
    /// Bodies in sustained contact (a stack, a pile, riders on a platform) share one owner,
    /// handed as a group, where bodies of `--group-min-owners` clusters meet; the rest as
    /// `spatial` (`seam_proxy::Group`; the default).
    #[default]
    Group,
}

impl AuthorityArg {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            AuthorityArg::Spatial => "spatial",
            AuthorityArg::Scripted => "scripted",
            AuthorityArg::Group => "group",
        }
    }
}

/// Which hand-offs a pod makes, and how the spatial policy decides them: the flags `seam
/// node`, `run` and `compare` share.
#[derive(Debug, Clone, Copy, PartialEq, clap::Args, serde::Serialize)]
pub struct AuthorityArgs {
    /// Which hand-offs the clusters make: `group` (authority follows entities into the region
    /// they are in, and bodies in sustained contact where three or more clusters' bodies meet
    /// share one owner), `spatial` (authority follows entities, no groups) or `scripted` (the
    /// scene's hand-offs only). Every kind makes the scene's hand-offs too.
    #[arg(long, value_enum, default_value_t = AuthorityArg::Group)]
    pub authority: AuthorityArg,
    /// Group: the fewest clusters whose bodies a group of touching bodies must hold before it
    /// is given one owner (2: every group across a seam, riders on a platform included).
    #[arg(long, default_value_t = GroupSettings::default().min_owners)]
    pub group_min_owners: usize,
    /// Spatial: how far past a seam, m, a body's centre must be (where it will be at the next
    /// replication frame) before it is handed over, and before it comes back.
    #[arg(long, default_value_t = SpatialSettings::default().margin)]
    pub handoff_margin: f32,
    /// Spatial: replication frames in a row the hand-off must be called for.
    #[arg(long, default_value_t = SpatialSettings::default().dwell_ticks)]
    pub handoff_dwell: u32,
}

impl Default for AuthorityArgs {
    fn default() -> Self {
        let spatial = SpatialSettings::default();
        Self {
            authority: AuthorityArg::Group,
            group_min_owners: GroupSettings::default().min_owners,
            handoff_margin: spatial.margin,
            handoff_dwell: spatial.dwell_ticks,
        }
    }
}

impl AuthorityArgs {
    /// Only the scene's hand-offs.
    pub fn scripted() -> Self {
        Self {
            authority: AuthorityArg::Scripted,
            ..Self::default()
        }
    }

    /// The cluster setting these flags stand for.
    pub fn mode(&self) -> AuthorityMode {
        match self.authority {
            AuthorityArg::Spatial => AuthorityMode::Spatial(SpatialSettings {
                margin: self.handoff_margin,
                dwell_ticks: self.handoff_dwell,
            }),
            AuthorityArg::Scripted => AuthorityMode::Scripted,
            AuthorityArg::Group => AuthorityMode::Group(GroupSettings {
                spatial: SpatialSettings {
                    margin: self.handoff_margin,
                    dwell_ticks: self.handoff_dwell,
                },
                min_owners: self.group_min_owners,
                ..GroupSettings::default()
            }),
        }
    }

    /// The flags again, for a pod's command line.
    pub fn to_args(&self) -> Vec<String> {
        vec![
            "--authority".into(),
            self.authority.name().into(),
            "--handoff-margin".into(),
            self.handoff_margin.to_string(),
            "--handoff-dwell".into(),
            self.handoff_dwell.to_string(),
            "--group-min-owners".into(),
            self.group_min_owners.to_string(),
        ]
    }

    /// How a table names the setting: `spatial` (with any non-default margin or dwell) or
    /// `scripted`.
    pub fn label(&self) -> String {
        let spatial = SpatialSettings::default();
        match self.authority {
            AuthorityArg::Scripted => "scripted".into(),
            AuthorityArg::Group if self.group_min_owners == GroupSettings::default().min_owners => {
                "group".into()
            }
            AuthorityArg::Group => format!("group (min owners {})", self.group_min_owners),
            AuthorityArg::Spatial
                if self.handoff_margin == spatial.margin
                    && self.handoff_dwell == spatial.dwell_ticks =>
            {
                "spatial".into()
            }
            AuthorityArg::Spatial => format!(
                "spatial (margin {} m, dwell {})",
                self.handoff_margin, self.handoff_dwell
            ),
        }
    }
}

/// How pods model their neighbours and move authority: the flags `seam node`, `run` and
/// `compare` share.
#[derive(Debug, Clone, Copy, PartialEq, clap::Args)]
pub struct ModelArgs {
    /// How neighbour entities are modelled.
    #[arg(long, value_enum, default_value_t = ProxyModeArg::Fixed)]
    pub proxy_mode: ProxyModeArg,
    /// Which hand-offs the clusters make.
    #[command(flatten)]
    pub authority: AuthorityArgs,
    /// A replication frame every this many ticks.
    #[arg(long, default_value_t = 1)]
    pub replication_interval: u64,
    /// Contacts do not push across the seam: proxies stay immovable (Fixed) or infinitely
    /// heavy (kinematic) whatever they meet, as before contact coupling (see
    /// `seam_sim::coupling`). For measuring what coupling buys.
    #[arg(long)]
    pub no_coupling: bool,
    /// Routed ops go after the step and land a tick late (caught up only for bodies touching
    /// nothing), instead of being exchanged before it and acting in the step they were
    /// written in (see `seam_proxy::ClusterConfig::exchange`). For measuring what the
    /// exchange buys and costs.
    #[arg(long)]
    pub no_exchange: bool,
    /// Quantized replication states: positions in fixed point (±0.49 mm), rotations as
    /// smallest-three (≤ 2·10⁻⁴ rad), velocities as half floats; 55 bytes a state instead of
    /// 77. Off: exact floats.
    #[arg(long)]
    pub quantize: bool,
    /// A full replication frame (keyframe) at most every this many ticks; frames between list
    /// only the states that changed and mark the rest unchanged, a bit each. Receivers see the
    /// same states either way; a lost keyframe can leave a proxy stale this long. 1: every
    /// frame whole.
    #[arg(long, default_value_t = seam_proxy::DEFAULT_KEYFRAME_TICKS)]
    pub keyframe_ticks: u64,
}

impl ModelArgs {
    /// The replication state encoding the flags ask for.
    pub fn state_encoding(&self) -> StateEncoding {
        if self.quantize {
            StateEncoding::Quantized
        } else {
            StateEncoding::Exact
        }
    }
}

/// `seam node`'s flags.
#[derive(Debug, Clone, clap::Args)]
pub struct NodeArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// The scene cluster this pod runs.
    #[arg(long, required_unless_present = "reference")]
    pub cluster: Option<String>,
    /// Run every cluster of the scene in this one world (the single-world reference).
    #[arg(long, conflicts_with = "cluster")]
    pub reference: bool,
    /// Transport URL: `shm`, `local` or `redis://[user:password@]host:port`. Read from
    /// `SEAM_TRANSPORT` when the flag is not given: a password there does not show in the
    /// process list (`seam run` and `seam chaos` start their pods that way).
    #[arg(
        long,
        env = "SEAM_TRANSPORT",
        default_value = "shm",
        hide_env_values = true
    )]
    pub transport: String,
    /// Ticks per second; 0 ticks as fast as the pod can.
    #[arg(long, default_value_t = 60.0)]
    pub rate: f64,
    /// Ticks to run (default: the scene's `ticks`).
    #[arg(long)]
    pub ticks: Option<u64>,
    /// Salts every cluster and entity id: pods of one run must share it, concurrent runs must
    /// not.
    #[arg(long, default_value = "seam")]
    pub run_id: String,
    /// How neighbours are modelled and authority moves.
    #[command(flatten)]
    pub model: ModelArgs,
    /// Stack this many copies of every grid entity along y (see `Scene::stacked`): the same
    /// scene with more entities.
    #[arg(long, default_value_t = 1)]
    pub layers: u32,
    /// Take a neighbour that was heard from and then stays silent this many ticks for dead:
    /// despawn its proxies and count it (0: never).
    #[arg(long, default_value_t = 60)]
    pub neighbour_timeout_ticks: u64,
    /// Tick 0 at this CLOCK_MONOTONIC time, ns (set by `seam run` so pods tick in phase).
    #[arg(long, hide = true)]
    pub start_at: Option<u64>,
    /// Rejoin a running world after a crash: start empty (what this cluster owned was adopted
    /// by its neighbours), fire no scripted events, and with --start-at carry on the world's
    /// tick count rather than start at 0.
    #[arg(long)]
    pub rejoin: bool,
    /// Record the first and last state of every body whose owner changes here (in the final
    /// report), so a run can judge hand-off jumps against a single world afterwards.
    #[arg(long)]
    pub track_flips: bool,
    /// Record this pod's tick by tick (what it owned and where, its proxies, the routed ops it
    /// applied, the contacts reported to it, its tick time) into FILE, a recording of one
    /// stream (see `seam inspect`; `seam run --record` merges its pods').
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// Write this pod's ledger into FILE as it ticks: a line for everything that happened here
    /// to a routed op or contact report, by name (sent, answered, applied, dropped, given up,
    /// unanswered at the end), and one for each entity it starts or stops owning, for
    /// following each op across pods and checking every entity has one owner at every tick
    /// (`seam chaos` does both).
    #[arg(long, value_name = "FILE")]
    pub ledger: Option<PathBuf>,
    /// Also write the final report (JSON) to this file.
    #[arg(long)]
    pub metrics: Option<PathBuf>,
    /// No progress on stderr.
    #[arg(long)]
    pub quiet: bool,
}

/// How often a pod reports progress.
const PROGRESS_EVERY: Duration = Duration::from_millis(250);

/// Set when SIGINT or SIGTERM arrives.
pub fn stop_flag() -> BenchResult<Arc<AtomicBool>> {
    let flag = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&flag))
            .map_err(|e| BenchError::io("handle", format!("signal {signal}"), e))?;
    }
    Ok(flag)
}

fn emit(out: &mut impl Write, line: &NodeLine) -> BenchResult<()> {
    let text = serde_json::to_string(line)?;
    writeln!(out, "{text}")
        .and_then(|()| out.flush())
        .map_err(|e| BenchError::io("write to", "stdout", e))
}

/// Runs one pod to the end of its ticks or until `stop` is set; writes JSON lines to `out`.
pub fn run_node(
    args: &NodeArgs,
    stop: &AtomicBool,
    out: &mut impl Write,
) -> BenchResult<NodeReport> {
    let scene = crate::scene::load(&args.scene)?.stacked(args.layers)?;
    let part = match (&args.cluster, args.reference) {
        (Some(name), false) => Part::Cluster(name.clone()),
        _ => Part::Reference,
    };
    let settings = pod_settings(args);
    let shown = seam_transport::redact_url(&args.transport);
    let mut pod =
        Pod::new(&scene, &part, &settings).context(format!("{}: {shown}", pod_name(&part)))?;
    let ticks = args.ticks.unwrap_or(scene.ticks);
    let fail = |e: seam_proxy::ClusterError| {
        BenchError::from(e).within(format!("{}: {shown}", pod_name(&part)))
    };
    let (mut schedule, first_tick, start_late_ns) =
        start_schedule(args, ticks, &mut pod).map_err(fail)?;
    tracing::info!(
        target: "seam::pod",
        pod = pod.name(),
        transport = %shown,
        rate_hz = args.rate,
        ticks,
        first_tick,
        "pod started"
    );
    let mut recorder = open_recording(args, &scene, ticks).context(pod_name(&part))?;
    let mut ledger = open_ledger(args, &pod).context(pod_name(&part))?;
    let ledger_failed =
        |e: std::io::Error| BenchError::io("write", "the ledger", e).within(pod_name(&part));
    let mut owners = crate::owners::OwnerLog::default();
    let started = Instant::now();
    let mut tally = Tally::new(&pod);
    pod.cluster_mut().time_phases(true);
    // The schedule stops the policy's hand-offs in the last ticks, so that those under way
    // are taken before the neighbours stop (see `Cluster::stop_policy_handoffs`).
    while let Some(due) = schedule
        .wait_for_next(pod.cluster_mut(), stop)
        .map_err(fail)?
    {
        tally.max_lag_ns = tally.max_lag_ns.max(due.lag_ns);
        let begun = Instant::now();
        let cpu_begun = seam_proxy::thread_cpu_ns();
        pod.tick().map_err(fail)?;
        if let Some(ledger) = &mut ledger {
            ledger
                .write(&ledger_entries(pod.last_events()))
                .map_err(ledger_failed)?;
            ledger
                .write_lines(&owners.lines(pod.cluster(), pod.last_events()))
                .map_err(ledger_failed)?;
        }
        if let Some(recorder) = &mut recorder {
            record_tick(recorder, &pod, begun, &mut tally)?;
        }
        let took = begun.elapsed().as_nanos() as u64;
        let cpu = seam_proxy::thread_cpu_ns().saturating_sub(cpu_begun);
        tally.ticked(&pod, due.tick, (took, cpu), schedule.period_ns());
        progress_due(args, &pod, due.tick + 1, ticks, &mut tally, out)?;
    }
    // Stopping on purpose: a neighbour still ticking (behind the schedule, or running
    // longer) must not take this pod for dead and adopt what it ends the run owning.
    pod.cluster_mut().leave().map_err(fail)?;
    if let Some(ledger) = &mut ledger {
        let mut last = ledger_entries(&pod.cluster_mut().take_events());
        last.extend(pod.cluster().unanswered_names());
        ledger.write(&last).map_err(ledger_failed)?;
    }
    let recorded = finish_recording(recorder, pod.name())?;
    let done = schedule.next_tick();
    let (entities_owned, proxies) = pod.population();
    let report = node_report(
        args,
        &pod,
        shown,
        (first_tick, done, ticks),
        (started, start_late_ns),
        tally,
        recorded,
    );
    tracing::info!(
        target: "seam::pod",
        pod = report.cluster,
        ticks = report.ticks,
        overruns = report.overruns,
        owned = entities_owned,
        proxies,
        stopped_by_signal = report.stopped_by_signal,
        "pod done"
    );
    if let Some(path) = &args.metrics {
        write_metrics(path, &report)?;
    }
    emit(out, &NodeLine::Report(Box::new(report.clone())))?;
    Ok(report)
}

/// The pod's schedule of `ticks` ticks, the first tick it runs, and how late it started (ns).
/// Tick k is due at anchor + k · period; pods of one run share the anchor.
fn start_schedule(
    args: &NodeArgs,
    ticks: u64,
    pod: &mut Pod,
) -> Result<(Schedule, u64, u64), seam_proxy::ClusterError> {
    let now = monotonic_ns();
    let schedule = Schedule::new(args.rate, ticks)?;
    Ok(match args.start_at {
        // A restarted pod joins the world at the tick the schedule is at.
        Some(at) if args.rejoin && at < now && schedule.period_ns().is_some() => {
            let mut schedule = schedule.starting_at(at);
            let first = schedule.join(pod.cluster_mut());
            (schedule, first, 0)
        }
        // A pod that starts after the shared start starts its ticks when it starts, rather
        // than racing through the ones it missed.
        Some(at) => (schedule.starting_at(at.max(now)), 0, now.saturating_sub(at)),
        None => (schedule, 0, 0),
    })
}

/// The recorder `--record` asks for.
fn open_recording(
    args: &NodeArgs,
    scene: &crate::scene::Scene,
    ticks: u64,
) -> BenchResult<Option<PodRecorder>> {
    let Some(path) = &args.record else {
        return Ok(None);
    };
    let table = EntityTable::new(scene, &args.run_id, ticks, args.rate, "seam node", false);
    Ok(Some(PodRecorder::create(path, table)?))
}

/// The ledger `--ledger` asks for.
fn open_ledger(args: &NodeArgs, pod: &Pod) -> BenchResult<Option<LedgerFile>> {
    let Some(path) = &args.ledger else {
        return Ok(None);
    };
    let ledger = LedgerFile::create(path, pod.cluster().id())
        .map_err(|e| BenchError::io("create the ledger", path.display(), e))?;
    Ok(Some(ledger))
}
/// Records the tick `pod` ran since `begun`: the tick's own time goes in the recording, the
/// recorder's in the tally.
fn record_tick(
    recorder: &mut PodRecorder,
    pod: &Pod,
    begun: Instant,
    tally: &mut Tally,
) -> BenchResult<()> {
    let stepped = begun.elapsed().as_nanos() as u64;
    recorder
        .observe(pod, stepped)
        .context(format!("{}: recording", pod.name()))?;
    tally
        .record_time
        .record(begun.elapsed().as_nanos() as u64 - stepped);
    Ok(())
}

/// Writes `report` as pretty JSON to `path` (`--metrics`).
fn write_metrics(path: &std::path::Path, report: &NodeReport) -> BenchResult<()> {
    let text = serde_json::to_string_pretty(report)?;
    std::fs::write(path, text).map_err(|e| BenchError::io("write metrics to", path.display(), e))
}

/// What a pod's loop counts as it ticks, and when it last said so.
struct Tally {
    tick_time: LatencyRecorder,
    tick_cpu: LatencyRecorder,
    phases: PhaseTally,
    record_time: LatencyRecorder,
    overruns: u64,
    max_lag_ns: u64,
    proxies_peak: usize,
    last_progress: Instant,
    ops_reported: [u64; 7],
}

impl Tally {
    fn new(pod: &Pod) -> Self {
        Self {
            tick_time: LatencyRecorder::default(),
            tick_cpu: LatencyRecorder::default(),
            phases: PhaseTally::default(),
            record_time: LatencyRecorder::default(),
            overruns: 0,
            max_lag_ns: 0,
            proxies_peak: 0,
            last_progress: Instant::now(),
            ops_reported: op_counts(&pod.cluster().stats()),
        }
    }
}

impl Tally {
    /// Counts tick `tick`, which took `took` ns of wall time and `cpu` ns of the thread's CPU
    /// (an overrun if longer than `period_ns`), with its phases, and a sample of the narrow
    /// phase every [`CENSUS_EVERY`] ticks (taken after the tick's CPU was read).
    fn ticked(&mut self, pod: &Pod, tick: u64, (took, cpu): (u64, u64), period_ns: Option<u64>) {
        self.tick_time.record(took);
        self.tick_cpu.record(cpu);
        self.phases.record(&pod.cluster().phase_cpu());
        if tick.is_multiple_of(CENSUS_EVERY) {
            self.phases.sample(&pod.cluster().sim().pair_census());
        }
        if period_ns.is_some_and(|p| took > p) {
            self.overruns += 1;
        }
    }
}

/// A progress line after tick `done` of `ticks` when one is due: a second after the last,
/// at the last tick, or after a tick that settled or sent a routed op or contact report (so
/// a pod killed a moment later leaves counts that add up with its neighbours'; see `seam
/// chaos`'s op accounting).
fn progress_due(
    args: &NodeArgs,
    pod: &Pod,
    done: u64,
    ticks: u64,
    tally: &mut Tally,
    out: &mut impl Write,
) -> BenchResult<()> {
    let ops_now = op_counts(&pod.cluster().stats());
    let ops_moved = ops_now != tally.ops_reported;
    if tally.last_progress.elapsed() < PROGRESS_EVERY && done != ticks && !ops_moved {
        return Ok(());
    }
    tally.ops_reported = ops_now;
    tally.last_progress = Instant::now();
    let (owned, proxies) = pod.population();
    tally.proxies_peak = tally.proxies_peak.max(proxies);
    let progress = progress_line(pod, done, ticks, tally, owned, proxies);
    if !args.quiet {
        tracing::info!(target: "seam::pod", "{progress}");
    }
    emit(out, &NodeLine::Progress(Box::new(progress)))
}

/// The pod settings `args` ask for.
fn pod_settings(args: &NodeArgs) -> PodSettings {
    PodSettings {
        proxy_mode: args.model.proxy_mode.into(),
        authority: args.model.authority.mode(),
        replication_interval: args.model.replication_interval,
        coupling: !args.model.no_coupling,
        exchange: !args.model.no_exchange,
        state_encoding: args.model.state_encoding(),
        keyframe_ticks: args.model.keyframe_ticks,
        neighbour_timeout_ticks: args.neighbour_timeout_ticks,
        rejoin: args.rejoin,
        track_flips: args.track_flips,
        ..PodSettings::new(&args.transport, &args.run_id)
    }
}

/// The progress line after tick `done` of `ticks`.
fn progress_line(
    pod: &Pod,
    done: u64,
    ticks: u64,
    tally: &Tally,
    owned: usize,
    proxies: usize,
) -> NodeProgress {
    NodeProgress {
        cluster: pod.name().to_owned(),
        tick: done,
        ticks,
        tick_p99_ns: tally.tick_time.summary().p99_ns,
        overruns: tally.overruns,
        entities_owned: owned,
        proxies,
        cluster_stats: pod.cluster().stats(),
        transport_stats: pod.cluster().transport_stats().into(),
        rss_kib: rss_kib(),
        ops_unanswered: pod.cluster().ops_unanswered() as u64,
        contacts_unanswered: pod.cluster().contacts_unanswered() as u64,
    }
}

/// Closes the recording, if any: its bytes and entity ticks.
fn finish_recording(recorder: Option<PodRecorder>, name: &str) -> BenchResult<(u64, u64)> {
    Ok(match recorder {
        Some(recorder) => {
            let counts = (recorder.bytes, recorder.entity_ticks);
            if recorder.unknown > 0 {
                tracing::warn!(
                    target: "seam::pod",
                    unknown = recorder.unknown,
                    "entities the recording's table does not know were left out"
                );
            }
            recorder.finish().context(format!("{name}: recording"))?;
            counts
        }
        None => (0, 0),
    })
}

/// The pod's report at the end: `ticks` (first, next, planned), `times` (started, how late
/// its start), the loop's tally and the recording's bytes and entity ticks.
fn node_report(
    args: &NodeArgs,
    pod: &Pod,
    shown: String,
    (first_tick, done, ticks): (u64, u64, u64),
    (started, start_late_ns): (Instant, u64),
    tally: Tally,
    recorded: (u64, u64),
) -> NodeReport {
    let (entities_owned, proxies) = pod.population();
    let transport = pod.cluster().transport_stats();
    NodeReport {
        cluster: pod.name().to_owned(),
        cluster_id: pod.cluster().id().to_string(),
        transport: shown,
        rate_hz: args.rate,
        ticks: done - first_tick,
        first_tick,
        ticks_planned: ticks,
        stopped_by_signal: done < ticks,
        wall_s: started.elapsed().as_secs_f64(),
        start_late_ns,
        tick_time: tally.tick_time,
        tick_cpu: tally.tick_cpu,
        phases: tally.phases,
        overruns: tally.overruns,
        max_lag_ns: tally.max_lag_ns,
        entities_at_start: pod.owned_at_start(),
        entities_owned,
        proxies,
        proxies_peak: tally.proxies_peak.max(proxies),
        cluster_stats: pod.cluster().stats(),
        transport_stats: transport.into(),
        events: pod.event_counts(),
        ops: pod.op_stages().clone(),
        ops_by_sender: pod.op_stages_by_sender(),
        projectile_hits: pod
            .projectile_hits()
            .iter()
            .map(|(&pair, &tick)| (pair, tick))
            .collect(),
        final_positions: pod.simulated_positions(),
        owned: pod.owned(),
        proxied: pod.proxied(),
        projectiles_seen: pod.projectiles_seen(),
        flips: pod.flips().to_vec(),
        recorded_bytes: recorded.0,
        recorded_entity_ticks: recorded.1,
        record_time: args.record.is_some().then_some(tally.record_time),
        rss_kib: rss_kib(),
        ops_unanswered: pod.cluster().ops_unanswered() as u64,
        contacts_unanswered: pod.cluster().contacts_unanswered() as u64,
    }
}

/// Resident memory of this process, KiB (0 if `/proc` cannot say).
pub fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|line| line.strip_prefix("VmRSS:"))
        .and_then(|rest| rest.split_whitespace().next()?.parse().ok())
        .unwrap_or(0)
}

fn pod_name(part: &Part) -> &str {
    match part {
        Part::Cluster(name) => name,
        Part::Reference => "reference",
    }
}

/// The routed-op and contact-report counters whose change makes a pod report progress at once.
fn op_counts(s: &seam_proxy::ClusterStats) -> [u64; 7] {
    [
        s.ops_routed,
        s.ops_applied + s.ops_dropped(),
        s.ops_acked,
        s.ops_forwarded,
        s.contacts_sent,
        s.contacts_received,
        s.contacts_acked + s.contacts_given_up + s.contacts_own_now,
    ]
}

/// The ledger entries among `events` (see `seam_proxy::LedgerEntry::from_event`).
fn ledger_entries(events: &[seam_proxy::TickEvent]) -> Vec<seam_proxy::LedgerEntry> {
    events
        .iter()
        .filter_map(|e| seam_proxy::LedgerEntry::from_event(e.tick, &e.event))
        .collect()
}
