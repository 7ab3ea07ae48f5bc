//! `seam chaos`: a scene's pods under faults on a schedule, and what survived.
//!
//! The pods run as in `seam run` (one `seam node` per cluster, staggered, shared schedule) on a
//! transport of their own: shared memory under a private prefix, or with `--transport redis` a
//! private `redis-server` this command starts (so it can kill it). Every `fault_every` one
//! fault, in turn:
//!
//! 1. **kill** a pod with SIGKILL and start it again 2 s later with `--rejoin` (empty, at the
//!    world's tick; its neighbours adopted what it owned and hand it back);
//! 2. **restart Redis** (SIGKILL, 1 s down, started again on the same port), with Redis only;
//! 3. **stop** a pod with SIGSTOP for 1 s, then SIGCONT.
//!
//! Kills happen in the first half of the run only (the others go on to the end), so every pod's
//! last incarnation lives at least half the run and its memory after warm-up can be judged. No
//! fault starts in the last 9 s, so the run ends calm.
//!
//! Between faults, every 250 ms, bursts of garbage and forged frames go into every channel
//! ([`Injector`]); none in the second before a fault or in the second after every pod ran again
//! after one (a pod stopped mid-command may drop its connection on waking, and with it what
//! was in its socket), and a due fault waits (up to 2 s) until the
//! pods' latest counters account for every injected frame delivered so far, so none is still in
//! a socket or in the server when a pod is killed or stopped or Redis restarted. Should some be
//! unaccounted for when the fault fires anyway, the report names the faults between which they
//! went unseen. A fault is *survived* when every pod has shown
//! progress again within 5 s of its end. At the end: faults by kind, injected frames against
//! the pods' refusal counters, entities lost or owned twice, ops and frames dropped by reason,
//! adoption, outages, panics, and each pod's memory after warm-up. Every pod life writes a
//! ledger (`seam node --ledger`), and every routed op and contact report is followed by name
//! across them ([`crate::ledger::follow`]): the sums of the pods' counters cannot tell an op
//! applied twice, nor one lost behind another counted twice; the names can.
//!
//! The run fails (see [`ChaosReport::holds`]) on anything chaos did not cause: a pod found
//! dead when it was picked for a kill, a pod that ended badly or sent no report, a panic on a
//! pod's stderr (counted after every reader has read to the end); and when a planned fault
//! kind was never injected, when the run outlives its deadline (the pods are then killed), when
//! adoptions and returns do not balance, when an op or report is lost or applied twice (by the
//! sums or by name), or when a pod's memory grows past its bound.

mod inject;
mod report;

use std::collections::VecDeque;
use std::ffi::OsString;
use std::path::PathBuf;
use std::process::Child;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rustix::process::{Pid, Signal, kill_process};
use seam_proxy::monotonic_ns;

use crate::ledger::{Followed, Life};
use crate::node::{NodeLine, NodeProgress, NodeReport};
use crate::pod::SceneIds;
use crate::redis_server::RedisServer;
use crate::run::{PodLaunch, PodLine, RunPlan, fresh_run_id, spawn_pod};
pub use inject::{InjectCounts, Injector};
pub use report::{
    ChaosReport, FaultCounts, FrameCounts, MEMORY_BOUND_PCT, MemoryRow, MemorySample, OpCounts,
    RecoveryCounts, document,
};

/// What `seam chaos` runs.
pub struct ChaosPlan {
    /// The scene file.
    pub scene: PathBuf,
    /// A private Redis server instead of shared memory.
    pub redis: bool,
    /// Ticks per second.
    pub rate: f64,
    /// How long the pods run.
    pub duration: Duration,
    /// Time from the end of one fault to the start of the next.
    pub fault_every: Duration,
    /// Copies of every grid entity stacked along y.
    pub layers: u32,
    /// Seeds which pod each fault hits and the garbage.
    pub seed: u64,
    /// The command that starts a pod, before its flags: `[seam, "node"]`.
    pub node_command: Vec<OsString>,
    /// A frame key for the pods (`key=` in their URL); the injector has none, so everything
    /// it sends must be refused as untagged.
    pub key: Option<String>,
    /// Pods record their streams into part files here (see [`crate::record`]).
    pub record_dir: Option<PathBuf>,
}

/// A fault, and what it waits for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fault {
    Kill,
    Stop,
    RestartRedis,
}

enum Phase {
    /// Between faults; the next one is due at the instant.
    Calm(Instant),
    /// Pod `index` is dead until the instant.
    Killed(usize, Instant),
    /// Pod `index` is stopped until the instant.
    Stopped(usize, Instant),
    /// The Redis server is down until the instant.
    RedisDown(Instant),
}

/// One pod: its current process and what it said.
struct PodState {
    name: String,
    start_at: u64,
    child: Option<Child>,
    latest: Option<(Instant, NodeProgress)>,
    /// Memory samples of the current incarnation.
    memory: Vec<MemorySample>,
    /// The current incarnation's place in the run's lives (its ledger).
    life: usize,
    report: Option<NodeReport>,
}

const KILLED_FOR: Duration = Duration::from_secs(2);
const STOPPED_FOR: Duration = Duration::from_secs(1);
const REDIS_DOWN_FOR: Duration = Duration::from_secs(1);
const BURST_EVERY: Duration = Duration::from_millis(250);
const QUIET_BEFORE_FAULT: Duration = Duration::from_secs(1);
/// No bursts for this long after every pod ran again after a fault.
const QUIET_AFTER_FAULT: Duration = Duration::from_secs(1);
/// How long a due fault waits for the pods to count every injected frame delivered.
const COUNTED_WITHIN: Duration = Duration::from_secs(2);
const SURVIVE_WITHIN: Duration = Duration::from_secs(5);
/// Time the run may take beyond its planned length before its pods are killed and it fails:
/// pods catch up after a stop on their shared schedule, so a healthy run ends within seconds.
const DEADLINE_SLACK: Duration = Duration::from_secs(60);

impl Drop for PodState {
    /// A run that ends early (an error, the deadline) leaves no pod behind.
    fn drop(&mut self) {
        if let Some(child) = &mut self.child
            && let Ok(None) = child.try_wait()
        {
            signal(child, Signal::CONT);
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

fn signal(child: &Child, signal: Signal) {
    if let Some(pid) = Pid::from_raw(child.id() as i32) {
        let _ = kill_process(pid, signal);
    }
}

/// Runs the plan; `progress` gets a line about once a second.
pub fn run(
    plan: &ChaosPlan,
    stop: &AtomicBool,
    mut progress: impl FnMut(&str),
) -> Result<ChaosReport, String> {
    let scene = crate::scene::load(&plan.scene)
        .map_err(|e| e.to_string())?
        .stacked(plan.layers)?;
    if !(plan.rate.is_finite() && plan.rate > 0.0) {
        return Err(format!("--rate must be positive, not {}", plan.rate));
    }
    let mut redis = if plan.redis {
        Some(RedisServer::start()?)
    } else {
        None
    };
    let run_id = fresh_run_id();
    let transport = match &redis {
        Some(server) => server.url(),
        None => format!("shm?prefix=seam_chaos_{}_", std::process::id()),
    };
    let ticks = (plan.duration.as_secs_f64() * plan.rate).ceil() as u64;
    let pod_transport = match &plan.key {
        Some(key) => {
            let joiner = if transport.contains('?') { '&' } else { '?' };
            format!("{transport}{joiner}key={key}")
        }
        None => transport.clone(),
    };
    let run_plan = RunPlan {
        rate: plan.rate,
        ticks: Some(ticks),
        layers: plan.layers,
        run_id: run_id.clone(),
        node_command: plan.node_command.clone(),
        start_delay: Duration::from_millis(1500),
        record_dir: plan.record_dir.clone(),
        ..RunPlan::new(plan.scene.clone(), pod_transport)
    };
    // Every life's ledger, in a directory of the run's own: removed at the end, unless they
    // show an op or report lost or applied twice.
    let mut ledgers = Ledgers::new(&run_id)?;
    let mut lives: Vec<Life> = Vec::new();
    let panics = Arc::new(AtomicU64::new(0));
    let (lines, incoming) = mpsc::channel::<PodLine>();
    let start_at = monotonic_ns() + run_plan.start_delay.as_nanos() as u64;
    let launched = Instant::now();
    let n = scene.clusters.len();
    let mut pods: Vec<PodState> = Vec::new();
    let mut readers: Vec<JoinHandle<()>> = Vec::new();
    let launch = |pods: &mut Vec<PodState>,
                  readers: &mut Vec<JoinHandle<()>>,
                  lives: &mut Vec<Life>,
                  index: usize,
                  rejoin: bool|
     -> Result<(), String> {
        let pod = &mut pods[index];
        let ledger = ledgers.path(&pod.name, lives.len());
        let (child, reader) = spawn_pod(
            &run_plan,
            &PodLaunch {
                index,
                cluster: &pod.name,
                start_at: pod.start_at,
                ticks,
                rejoin,
                panics: &panics,
                transport: None,
                namespace: None,
                ledger: Some(&ledger),
            },
            &lines,
        )?;
        readers.push(reader);
        pod.life = lives.len();
        lives.push(Life {
            path: ledger,
            killed_after: None,
        });
        pod.child = Some(child);
        pod.latest = None;
        pod.memory.clear();
        Ok(())
    };
    for (index, cluster) in scene.clusters.iter().enumerate() {
        pods.push(PodState {
            name: cluster.name.clone(),
            start_at: start_at + run_plan.pod_offset_ns(index, n as u64),
            child: None,
            latest: None,
            memory: Vec::new(),
            life: 0,
            report: None,
        });
        launch(&mut pods, &mut readers, &mut lives, index, false)?;
    }
    let ids = SceneIds::new(&run_id, &scene.name);
    let clusters = scene
        .clusters
        .iter()
        .map(|c| ids.cluster(&c.name))
        .collect();
    let mut injector = Injector::new(&transport, clusters, plan.seed)?;

    let mut rng = plan.seed.max(1);
    let mut pick = |bound: usize| {
        rng = rng
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((rng >> 33) as usize) % bound.max(1)
    };
    let mut kinds = VecDeque::from(if plan.redis {
        vec![Fault::Kill, Fault::RestartRedis, Fault::Stop]
    } else {
        vec![Fault::Kill, Fault::Stop]
    });
    let first_fault = launched + run_plan.start_delay + plan.fault_every;
    let last_fault_by = launched
        + run_plan.start_delay
        + plan
            .duration
            .saturating_sub(KILLED_FOR + SURVIVE_WITHIN + Duration::from_secs(2));
    let kills_until = launched + run_plan.start_delay + plan.duration / 2;
    let deadline = launched + run_plan.start_delay + plan.duration + DEADLINE_SLACK;
    let mut phase = Phase::Calm(first_fault);
    let mut faults = FaultCounts::default();
    let mut fault_log: Vec<crate::record::Fault> = Vec::new();
    let log_fault =
        |fault_log: &mut Vec<crate::record::Fault>, stream: Option<usize>, what: String| {
            let since = monotonic_ns().saturating_sub(start_at) as f64;
            fault_log.push(crate::record::Fault {
                tick: (since * plan.rate / 1e9) as u64,
                stream: stream.map(|s| s as u16),
                what,
            });
        };
    let mut pending_survival: Option<(Fault, Instant)> = None;
    let mut dead_incarnations: Vec<NodeProgress> = Vec::new();
    let mut failed_faults: Vec<String> = Vec::new();
    let mut next_burst = Instant::now();
    let mut last_shown = Instant::now();
    let mut problems: Vec<String> = Vec::new();
    let mut accounting_slips: Vec<String> = Vec::new();
    let mut unseen_before = (0i64, 0i64);
    // When the due fault could first have fired (its wait for the counts starts there, not
    // at its due time, which survival of the fault before may have passed long ago).
    let mut due_since: Option<Instant> = None;

    let take =
        |pods: &mut Vec<PodState>, (index, line): PodLine, problems: &mut Vec<String>| match line {
            Ok(NodeLine::Progress(p)) => {
                let pod = &mut pods[index];
                pod.memory.push(MemorySample {
                    at_s: launched.elapsed().as_secs_f64(),
                    rss_kib: p.rss_kib,
                    owned: p.entities_owned,
                });
                pod.latest = Some((Instant::now(), *p));
            }
            Ok(NodeLine::Report(r)) => pods[index].report = Some(*r),
            Err(e) => problems.push(format!("pod {:?}: {e}", pods[index].name)),
        };
    loop {
        match incoming.recv_timeout(Duration::from_millis(20)) {
            Ok(line) => take(&mut pods, line, &mut problems),
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
        let all_exited = pods.iter_mut().all(|p| match &mut p.child {
            Some(child) => matches!(child.try_wait(), Ok(Some(_))),
            None => false,
        });
        if all_exited && matches!(phase, Phase::Calm(_)) {
            // Let the readers deliver the last lines.
            while let Ok(line) = incoming.recv_timeout(Duration::from_millis(200)) {
                take(&mut pods, line, &mut problems);
            }
            break;
        }
        if Instant::now() > deadline {
            let mut running = Vec::new();
            for pod in &mut pods {
                if let Some(child) = &mut pod.child
                    && matches!(child.try_wait(), Ok(None))
                {
                    running.push(pod.name.clone());
                }
            }
            problems.push(format!(
                "deadline: {:.0} s after launch, pods {running:?} still ran; killed",
                launched.elapsed().as_secs_f64()
            ));
            for pod in &mut pods {
                if let Some(child) = &mut pod.child {
                    signal(child, Signal::CONT);
                    let _ = child.kill();
                }
            }
            break;
        }
        if stop.load(Ordering::Relaxed) {
            for pod in &pods {
                if let Some(child) = &pod.child {
                    signal(child, Signal::CONT);
                    signal(child, Signal::TERM);
                }
            }
        }
        let now = Instant::now();
        if let Some(r) = &redis
            && !r.is_running()
            && !matches!(phase, Phase::RedisDown(_))
        {
            return Err("the Redis server is down outside a fault".into());
        }
        if let Some((fault, ended)) = pending_survival {
            let fresh = |pod: &PodState| pod.latest.as_ref().is_some_and(|(at, _)| *at > ended);
            if pods.iter().all(fresh) {
                faults.survived(fault);
                pending_survival = None;
                // A pod that ran again may still drop its connection to the fault (a command
                // that timed out while it was stopped): no bursts until it has had time to.
                next_burst = next_burst.max(now + QUIET_AFTER_FAULT);
            } else if now > ended + SURVIVE_WITHIN {
                failed_faults.push(format!("{fault:?}: not every pod ran again within 5 s"));
                pending_survival = None;
            }
        }
        phase = match phase {
            Phase::Calm(due) => {
                let all_running = pods.iter().all(|p| p.latest.is_some());
                if all_running
                    && pending_survival.is_none()
                    && now >= next_burst
                    && now + QUIET_BEFORE_FAULT < due
                    && !stop.load(Ordering::Relaxed)
                {
                    injector.burst()?;
                    next_burst = now + BURST_EVERY;
                } else {
                    injector.observe()?;
                }
                let fault_due =
                    now >= due && now < last_fault_by && pending_survival.is_none() && all_running;
                let waited_since = if fault_due {
                    *due_since.get_or_insert(now)
                } else {
                    now
                };
                // A fault waits (up to `COUNTED_WITHIN`) until every injected frame delivered
                // so far is counted by a pod: one still in a pod's socket when it is killed or
                // stopped, or in the server when it is restarted, would be lost by the fault,
                // not by seam. What is still unseen when it fires is noted where it went.
                let unseen = if fault_due {
                    report::injected_unseen(
                        plan.key.is_some(),
                        &injector.counts(),
                        pods.iter()
                            .filter_map(|p| p.latest.as_ref())
                            .map(|(_, p)| p)
                            .chain(&dead_incarnations)
                            .map(|p| (&p.cluster_stats, &p.transport_stats)),
                    )
                } else {
                    unseen_before
                };
                if fault_due && (unseen == unseen_before || now >= waited_since + COUNTED_WITHIN) {
                    due_since = None;
                    if unseen != unseen_before {
                        let last_fault = fault_log.last().map_or("the start".into(), |f| {
                            format!("{} (tick {})", f.what, f.tick)
                        });
                        accounting_slips.push(format!(
                            "{:+} garbage, {:+} forged deliveries between {last_fault} and \
                             {:.1} s",
                            unseen.0 - unseen_before.0,
                            unseen.1 - unseen_before.1,
                            launched.elapsed().as_secs_f64()
                        ));
                        unseen_before = unseen;
                    }
                    let mut fault = kinds[0];
                    kinds.rotate_left(1);
                    if fault == Fault::Kill && now >= kills_until {
                        fault = kinds[0];
                        kinds.rotate_left(1);
                    }
                    let index = pick(n);
                    match fault {
                        Fault::Kill => {
                            if let Some(mut child) = pods[index].child.take() {
                                // A pod that is already gone died of something else.
                                match child.try_wait() {
                                    Ok(None) => {
                                        let _ = child.kill();
                                    }
                                    Ok(Some(status)) => problems.push(format!(
                                        "pod {:?} had exited ({status}) when picked for a kill",
                                        pods[index].name
                                    )),
                                    Err(e) => {
                                        problems.push(format!("pod {:?}: {e}", pods[index].name))
                                    }
                                }
                                let _ = child.wait();
                            }
                            // The dead incarnation's last counters: read what it wrote.
                            let until = Instant::now() + Duration::from_millis(150);
                            while let Some(left) = until.checked_duration_since(Instant::now()) {
                                if let Ok(line) = incoming.recv_timeout(left) {
                                    take(&mut pods, line, &mut problems);
                                }
                            }
                            let last = pods[index].latest.take().map(|(_, last)| last);
                            lives[pods[index].life].killed_after =
                                Some(last.as_ref().map_or(0, |last| last.tick));
                            dead_incarnations.extend(last);
                            faults.kill += 1;
                            log_fault(
                                &mut fault_log,
                                Some(index),
                                format!("pod {} killed", pods[index].name),
                            );
                            Phase::Killed(index, now + KILLED_FOR)
                        }
                        Fault::Stop => {
                            if let Some(child) = &pods[index].child {
                                signal(child, Signal::STOP);
                            }
                            faults.stop += 1;
                            log_fault(
                                &mut fault_log,
                                Some(index),
                                format!("pod {} stopped", pods[index].name),
                            );
                            Phase::Stopped(index, now + STOPPED_FOR)
                        }
                        Fault::RestartRedis => {
                            if let Some(server) = &mut redis {
                                server.kill();
                            }
                            faults.redis_restart += 1;
                            log_fault(&mut fault_log, None, "Redis server killed".into());
                            Phase::RedisDown(now + REDIS_DOWN_FOR)
                        }
                    }
                } else {
                    Phase::Calm(due)
                }
            }
            Phase::Killed(index, until) if now >= until => {
                launch(&mut pods, &mut readers, &mut lives, index, true)?;
                log_fault(
                    &mut fault_log,
                    Some(index),
                    format!("pod {} restarted", pods[index].name),
                );
                pending_survival = Some((Fault::Kill, now));
                Phase::Calm(now + plan.fault_every)
            }
            Phase::Stopped(index, until) if now >= until => {
                if let Some(child) = &pods[index].child {
                    signal(child, Signal::CONT);
                }
                log_fault(
                    &mut fault_log,
                    Some(index),
                    format!("pod {} continued", pods[index].name),
                );
                pending_survival = Some((Fault::Stop, now));
                Phase::Calm(now + plan.fault_every)
            }
            Phase::RedisDown(until) if now >= until => {
                if let Some(server) = &mut redis {
                    server.restart()?;
                }
                log_fault(&mut fault_log, None, "Redis server restarted".into());
                pending_survival = Some((Fault::RestartRedis, now));
                Phase::Calm(now + plan.fault_every)
            }
            other => other,
        };
        if last_shown.elapsed() >= Duration::from_secs(1) {
            last_shown = Instant::now();
            let ticks_now: Vec<String> = pods
                .iter()
                .map(|p| match &p.latest {
                    Some((_, l)) => format!("{} {}/{}", p.name, l.tick, l.ticks),
                    None => format!("{} -", p.name),
                })
                .collect();
            let c = injector.counts();
            progress(&format!(
                "{:>5.0} s  {}  faults: {} kill, {} stop, {} redis; injected {} garbage, {} forged",
                launched.elapsed().as_secs_f64(),
                ticks_now.join(", "),
                faults.kill,
                faults.stop,
                faults.redis_restart,
                c.garbage_frames,
                c.forged_frames
            ));
        }
    }
    let mut exited_badly = 0;
    for pod in &mut pods {
        if let Some(mut child) = pod.child.take() {
            let status = child
                .wait()
                .map_err(|e| format!("pod {:?}: {e}", pod.name))?;
            if !status.success() {
                exited_badly += 1;
                problems.push(format!("pod {:?} exited with {status}", pod.name));
            }
        }
        if pod.report.is_none() {
            problems.push(format!("pod {:?} sent no report", pod.name));
        }
    }
    // Every pod has exited, so every stderr is closed: the readers end once they have read
    // (and counted) the last line.
    for reader in readers {
        if reader.join().is_err() {
            problems.push("a stderr reader panicked".into());
        }
    }
    let reports: Vec<NodeReport> = pods.iter().filter_map(|p| p.report.clone()).collect();
    let by_name = crate::ledger::follow(&lives).unwrap_or_else(|e| {
        problems.push(format!("cannot read the pods' ledgers: {e}"));
        Followed::default()
    });
    if !(by_name.ops.holds() && by_name.contacts.holds()) {
        ledgers.remove = false;
        problems.push(format!(
            "the pods' ledgers are kept in {} for tracing",
            ledgers.dir.display()
        ));
    }
    let memory = pods
        .iter()
        .map(|p| MemoryRow::new(&p.name, &p.memory))
        .collect();
    Ok(ChaosReport::new(
        &scene,
        &run_id,
        report::Inputs {
            transport: seam_transport::redact_url(&transport),
            keyed: plan.key.is_some(),
            redis: plan.redis,
            rate: plan.rate,
            duration_s: plan.duration.as_secs_f64(),
            wall_s: launched.elapsed().as_secs_f64(),
            faults,
            failed_faults,
            injected: injector.counts(),
            reports: &reports,
            dead_incarnations: &dead_incarnations,
            panics: panics.load(Ordering::Relaxed),
            exited_badly,
            problems,
            memory,
            fault_log,
            accounting_slips,
            by_name,
        },
    ))
}

/// The directory of the pods' ledgers: the run's own, removed when the run ends unless
/// `remove` is cleared.
struct Ledgers {
    dir: PathBuf,
    remove: bool,
}

impl Ledgers {
    fn new(run_id: &str) -> Result<Self, String> {
        let dir = std::env::temp_dir().join(format!("seam-chaos-ledgers-{run_id}"));
        std::fs::create_dir_all(&dir)
            .map_err(|e| format!("cannot make {} for the ledgers: {e}", dir.display()))?;
        Ok(Self { dir, remove: true })
    }

    /// The ledger of life `life` (numbered across the run) of pod `name`.
    fn path(&self, name: &str, life: usize) -> PathBuf {
        self.dir.join(format!("{name}-{life}.ledger"))
    }
}

impl Drop for Ledgers {
    fn drop(&mut self) {
        if self.remove {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}
