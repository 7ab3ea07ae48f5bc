//! One chaos run in progress: its pods, its faults and bursts, and what it has seen, one step
//! of the loop at a time ([`Runner::step`]) until [`Runner::finish`] makes the report.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use rustix::process::Signal;
use seam_proxy::monotonic_ns;

use super::broker::{PRIMARY_DOWN_FOR, REDIS_DOWN_FOR, Server};
use super::pods::Pods;
use super::schedule::{Fault, KILLED_FOR, Phase, STOPPED_FOR, SURVIVE_WITHIN, Schedule};
use super::{ChaosPlan, ChaosReport, FaultCounts, Injector, MemoryRow, report};
use crate::error::{BenchError, BenchResult};
use crate::ledger::Followed;
use crate::node::{NodeProgress, NodeReport};
use crate::pod::SceneIds;
use crate::run::{RunPlan, fresh_run_id};
use crate::scene::Scene;

const BURST_EVERY: Duration = Duration::from_millis(250);
const QUIET_BEFORE_FAULT: Duration = Duration::from_secs(1);
/// No bursts for this long after every pod ran again after a fault.
const QUIET_AFTER_FAULT: Duration = Duration::from_secs(1);
/// How long a due fault waits for the pods to count every injected frame delivered.
const COUNTED_WITHIN: Duration = Duration::from_secs(2);

/// A chaos run in progress. Fields drop in order: the pods (killed) before the server.
pub(super) struct Runner<'p> {
    plan: &'p ChaosPlan,
    pods: Pods,
    server: Server,
    scene: Scene,
    run_id: String,
    transport: String,
    /// When the pods' first tick is due (monotonic ns).
    start_at: u64,
    launched: Instant,
    injector: Injector,
    schedule: Schedule,
    phase: Phase,
    faults: FaultCounts,
    fault_log: Vec<crate::record::Fault>,
    pending_survival: Option<(Fault, Instant)>,
    /// Killed lives' last progress lines.
    dead_incarnations: Vec<NodeProgress>,
    failed_faults: Vec<String>,
    next_burst: Instant,
    last_shown: Instant,
    problems: Vec<String>,
    accounting_slips: Vec<String>,
    unseen_before: (i64, i64),
    /// When the due fault could first have fired (its wait for the counts starts there, not
    /// at its due time, which survival of the fault before may have passed long ago).
    due_since: Option<Instant>,
}

impl<'p> Runner<'p> {
    /// Starts the plan's server (if any) and pods, and the injector.
    pub(super) fn start(plan: &'p ChaosPlan) -> BenchResult<Self> {
        let scene = crate::scene::load(&plan.scene)?.stacked(plan.layers)?;
        if !(plan.rate.is_finite() && plan.rate > 0.0) {
            return Err(BenchError::flag(
                "--rate",
                format!("must be positive, not {}", plan.rate),
            ));
        }
        let server = Server::start(plan.broker)?;
        let run_id = fresh_run_id();
        let transport = server
            .url()
            .unwrap_or_else(|| format!("shm?prefix=seam_chaos_{}_", std::process::id()));
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
        let start_at = monotonic_ns() + run_plan.start_delay.as_nanos() as u64;
        let launched = Instant::now();
        let schedule = Schedule::new(
            launched,
            run_plan.start_delay,
            plan.duration,
            plan.fault_every,
            server.faults(),
            plan.seed,
        );
        let names: Vec<String> = scene.clusters.iter().map(|c| c.name.clone()).collect();
        let pods = Pods::launch_all(run_plan, &names, start_at, ticks, launched)?;
        let ids = SceneIds::new(&run_id, &scene.name);
        let clusters = names.iter().map(|name| ids.cluster(name)).collect();
        let injector = Injector::new(&transport, clusters, plan.seed)?;
        Ok(Self {
            plan,
            pods,
            server,
            scene,
            run_id,
            transport,
            start_at,
            launched,
            injector,
            phase: Phase::Calm(schedule.first_fault),
            schedule,
            faults: FaultCounts::default(),
            fault_log: Vec::new(),
            pending_survival: None,
            dead_incarnations: Vec::new(),
            failed_faults: Vec::new(),
            next_burst: Instant::now(),
            last_shown: Instant::now(),
            problems: Vec::new(),
            accounting_slips: Vec::new(),
            unseen_before: (0, 0),
            due_since: None,
        })
    }

    /// One turn of the loop: a line taken (or 20 ms waited), the end and the deadline
    /// checked, a stop passed on, survival judged, the phase moved on, progress shown. False
    /// when the run is over.
    pub(super) fn step(
        &mut self,
        stop: &AtomicBool,
        progress: &mut impl FnMut(&str),
    ) -> BenchResult<bool> {
        if !self
            .pods
            .receive(Duration::from_millis(20), &mut self.problems)
        {
            return Ok(false);
        }
        if self.pods.all_exited() && matches!(self.phase, Phase::Calm(_)) {
            // Let the readers deliver the last lines.
            (self.pods).drain_while_coming(Duration::from_millis(200), &mut self.problems);
            return Ok(false);
        }
        if Instant::now() > self.schedule.deadline {
            self.kill_at_deadline();
            return Ok(false);
        }
        let stopping = stop.load(Ordering::Relaxed);
        if stopping {
            for pod in &self.pods.all {
                pod.signal(Signal::CONT);
                pod.signal(Signal::TERM);
            }
        }
        let now = Instant::now();
        if !matches!(self.phase, Phase::RedisDown(_)) && !self.server.is_running() {
            return Err(BenchError::process(
                "the run's Redis server or cluster",
                "down outside a fault",
            ));
        }
        self.judge_survival(now);
        self.phase = match self.phase {
            Phase::Calm(due) => self.calm(now, due, stop)?,
            Phase::Killed(index, until) if now >= until => {
                self.pods.launch(index, true)?;
                self.log_fault(Some(index), format!("pod {} restarted", self.name(index)));
                self.ended(Fault::Kill, now)
            }
            Phase::Stopped(index, until) if now >= until => {
                self.pods.all[index].signal(Signal::CONT);
                let tick = self.world_tick();
                let life = self.pods.all[index].life;
                if let Some(stop) = self.pods.lives[life].stopped.last_mut() {
                    stop.1 = tick;
                }
                self.log_fault(Some(index), format!("pod {} continued", self.name(index)));
                self.ended(Fault::Stop, now)
            }
            Phase::RedisDown(until) if now >= until => {
                let what = self.server.bring_back()?;
                self.log_fault(None, what);
                let fault = match self.server {
                    Server::Cluster { .. } => Fault::KillPrimary,
                    _ => Fault::RestartRedis,
                };
                self.ended(fault, now)
            }
            other => other,
        };
        self.show(progress);
        Ok(true)
    }

    fn name(&self, index: usize) -> &str {
        &self.pods.all[index].name
    }

    /// The phase after `fault` ended at `now`: its survival pending, the next fault due.
    fn ended(&mut self, fault: Fault, now: Instant) -> Phase {
        self.pending_survival = Some((fault, now));
        Phase::Calm(now + self.plan.fault_every)
    }

    /// Pods still running past the deadline: noted and killed.
    fn kill_at_deadline(&mut self) {
        let running: Vec<String> = (self.pods.all.iter_mut())
            .filter_map(|pod| pod.running().then(|| pod.name.clone()))
            .collect();
        self.problems.push(format!(
            "deadline: {:.0} s after launch, pods {running:?} still ran; killed",
            self.launched.elapsed().as_secs_f64()
        ));
        for pod in &mut self.pods.all {
            if let Some(child) = &mut pod.child {
                super::pods::signal(child, Signal::CONT);
                let _ = child.kill();
            }
        }
    }

    /// A fault is survived once every pod has shown progress after its end, and fails when
    /// one has not within `SURVIVE_WITHIN`.
    fn judge_survival(&mut self, now: Instant) {
        let Some((fault, ended)) = self.pending_survival else {
            return;
        };
        let fresh =
            |pod: &super::pods::PodState| pod.latest.as_ref().is_some_and(|(at, _)| *at > ended);
        if self.pods.all.iter().all(fresh) {
            self.faults.survived(fault);
            self.pending_survival = None;
            // A pod that ran again may still drop its connection to the fault (a command
            // that timed out while it was stopped): no bursts until it has had time to.
            self.next_burst = self.next_burst.max(now + QUIET_AFTER_FAULT);
        } else if now > ended + SURVIVE_WITHIN {
            (self.failed_faults).push(format!("{fault:?}: not every pod ran again within 5 s"));
            self.pending_survival = None;
        }
    }

    /// Between faults: a burst when one is due and quiet allows, else the injector's counts
    /// read; the fault due at `due` fired once the pods have counted what was delivered.
    fn calm(&mut self, now: Instant, due: Instant, stop: &AtomicBool) -> BenchResult<Phase> {
        let all_running = self.pods.all_running();
        if all_running
            && self.pending_survival.is_none()
            && now >= self.next_burst
            && now + QUIET_BEFORE_FAULT < due
            && !stop.load(Ordering::Relaxed)
        {
            self.injector.burst()?;
            self.next_burst = now + BURST_EVERY;
        } else {
            self.injector.observe()?;
        }
        let fault_due = now >= due
            && now < self.schedule.last_fault_by
            && self.pending_survival.is_none()
            && all_running;
        if !fault_due {
            return Ok(Phase::Calm(due));
        }
        let waited_since = *self.due_since.get_or_insert(now);
        // A fault waits (up to `COUNTED_WITHIN`) until every injected frame delivered so far
        // is counted by a pod: one still in a pod's socket when it is killed or stopped, or
        // in the server when it is restarted, would be lost by the fault, not by seam. What
        // is still unseen when it fires is noted where it went.
        let unseen = self.injected_unseen();
        if unseen != self.unseen_before && now < waited_since + COUNTED_WITHIN {
            return Ok(Phase::Calm(due));
        }
        self.due_since = None;
        if unseen != self.unseen_before {
            self.note_slip(unseen);
        }
        let fault = self.schedule.next_kind(now);
        let index = self.schedule.pick(self.pods.all.len());
        self.fire(fault, index, now)
    }

    /// Injected deliveries the pods' latest counters (the killed lives' last) do not count.
    fn injected_unseen(&self) -> (i64, i64) {
        report::injected_unseen(
            self.plan.key.is_some(),
            &self.injector.counts(),
            (self.pods.all.iter())
                .filter_map(|p| p.latest.as_ref())
                .map(|(_, p)| p)
                .chain(&self.dead_incarnations)
                .map(|p| (&p.cluster_stats, &p.transport_stats)),
        )
    }

    /// Deliveries went unseen since the last fault: noted with where.
    fn note_slip(&mut self, unseen: (i64, i64)) {
        let last_fault = (self.fault_log.last()).map_or("the start".into(), |f| {
            format!("{} (tick {})", f.what, f.tick)
        });
        self.accounting_slips.push(format!(
            "{:+} garbage, {:+} forged deliveries between {last_fault} and {:.1} s",
            unseen.0 - self.unseen_before.0,
            unseen.1 - self.unseen_before.1,
            self.launched.elapsed().as_secs_f64()
        ));
        self.unseen_before = unseen;
    }

    /// Fires `fault` (at pod `index` where it hits one, or at its replication channel's slot);
    /// the phase it starts.
    fn fire(&mut self, fault: Fault, index: usize, now: Instant) -> BenchResult<Phase> {
        self.faults.injected(fault);
        Ok(match fault {
            Fault::Kill => {
                self.kill(index);
                self.log_fault(Some(index), format!("pod {} killed", self.name(index)));
                Phase::Killed(index, now + KILLED_FOR)
            }
            Fault::Stop => {
                self.pods.all[index].signal(Signal::STOP);
                let (tick, life) = (self.world_tick(), self.pods.all[index].life);
                self.pods.lives[life].stopped.push((tick, u64::MAX));
                self.log_fault(Some(index), format!("pod {} stopped", self.name(index)));
                Phase::Stopped(index, now + STOPPED_FOR)
            }
            Fault::RestartRedis | Fault::KillPrimary => {
                let what = self.server.take_down(&self.channel_of(index))?;
                self.log_fault(None, what);
                let down_for = match fault {
                    Fault::KillPrimary => PRIMARY_DOWN_FOR,
                    _ => REDIS_DOWN_FOR,
                };
                Phase::RedisDown(now + down_for)
            }
            Fault::MoveSlot => {
                let what = self.server.move_slot(&self.channel_of(index))?;
                self.log_fault(Some(index), what);
                self.ended(Fault::MoveSlot, now)
            }
        })
    }

    /// The replication channel of pod `index`'s cluster.
    fn channel_of(&self, index: usize) -> String {
        let ids = SceneIds::new(&self.run_id, &self.scene.name);
        seam_proxy::replication(ids.cluster(self.name(index)))
    }

    /// Kills pod `index` and keeps its life's last counters.
    fn kill(&mut self, index: usize) {
        let pod = &mut self.pods.all[index];
        if let Some(mut child) = pod.child.take() {
            // A pod that is already gone died of something else.
            match child.try_wait() {
                Ok(None) => {
                    let _ = child.kill();
                }
                Ok(Some(status)) => self.problems.push(format!(
                    "pod {:?} had exited ({status}) when picked for a kill",
                    pod.name
                )),
                Err(e) => self.problems.push(format!("pod {:?}: {e}", pod.name)),
            }
            let _ = child.wait();
        }
        // The dead incarnation's last counters: read what it wrote.
        (self.pods).drain_for(Duration::from_millis(150), &mut self.problems);
        let pod = &mut self.pods.all[index];
        let last = pod.latest.take().map(|(_, last)| last);
        self.pods.lives[pod.life].killed_after = Some(last.as_ref().map_or(0, |last| last.tick));
        self.dead_incarnations.extend(last);
    }

    /// The tick the pods' shared schedule is at now.
    fn world_tick(&self) -> u64 {
        let since = monotonic_ns().saturating_sub(self.start_at) as f64;
        (since * self.plan.rate / 1e9) as u64
    }

    /// Logs a fault (or its end) at the pods' current tick.
    fn log_fault(&mut self, stream: Option<usize>, what: String) {
        self.fault_log.push(crate::record::Fault {
            tick: self.world_tick(),
            stream: stream.map(|s| s as u16),
            what,
        });
    }

    /// A progress line about once a second.
    fn show(&mut self, progress: &mut impl FnMut(&str)) {
        if self.last_shown.elapsed() < Duration::from_secs(1) {
            return;
        }
        self.last_shown = Instant::now();
        let ticks_now: Vec<String> = (self.pods.all.iter())
            .map(|p| match &p.latest {
                Some((_, l)) => format!("{} {}/{}", p.name, l.tick, l.ticks),
                None => format!("{} -", p.name),
            })
            .collect();
        let c = self.injector.counts();
        let f = &self.faults;
        progress(&format!(
            "{:>5.0} s  {}  faults: {} kill, {} stop, {} redis, {} primary, {} slot; injected {} \
             garbage, {} forged",
            self.launched.elapsed().as_secs_f64(),
            ticks_now.join(", "),
            f.kill,
            f.stop,
            f.redis_restart,
            f.primary_kill,
            f.slot_move,
            c.garbage_frames,
            c.forged_frames
        ));
    }

    /// Waits for every pod, reads every ledger, and makes the report.
    pub(super) fn finish(mut self) -> BenchResult<ChaosReport> {
        let mut exited_badly = 0;
        for pod in &mut self.pods.all {
            if let Some(mut child) = pod.child.take() {
                let status = child
                    .wait()
                    .map_err(|e| BenchError::io("wait for", format!("pod {:?}", pod.name), e))?;
                if !status.success() {
                    exited_badly += 1;
                    (self.problems).push(format!("pod {:?} exited with {status}", pod.name));
                }
            }
            if pod.report.is_none() {
                (self.problems).push(format!("pod {:?} sent no report", pod.name));
            }
        }
        // Every pod has exited, so every stderr is closed: the readers end once they have
        // read (and counted) the last line.
        for reader in std::mem::take(&mut self.pods.readers) {
            if reader.join().is_err() {
                self.problems.push("a stderr reader panicked".into());
            }
        }
        let reports: Vec<NodeReport> = (self.pods.all.iter())
            .filter_map(|p| p.report.clone())
            .collect();
        let by_name = crate::ledger::follow(&self.pods.lives).unwrap_or_else(|e| {
            (self.problems).push(format!("cannot read the pods' ledgers: {e}"));
            Followed::default()
        });
        let owners = crate::owners::check(&self.pods.lives, self.pods.ticks).unwrap_or_else(|e| {
            (self.problems).push(format!("cannot read the pods' owner lines: {e}"));
            crate::owners::OwnerCheck {
                unreadable_lines: 1,
                ..Default::default()
            }
        });
        if !(by_name.ops.holds() && by_name.contacts.holds() && owners.holds()) {
            self.pods.ledgers.remove = false;
            self.problems.push(format!(
                "the pods' ledgers are kept in {} for tracing",
                self.pods.ledgers.dir.display()
            ));
        }
        let memory = (self.pods.all.iter())
            .map(|p| MemoryRow::new(&p.name, &p.memory))
            .collect();
        let plan = self.plan;
        Ok(ChaosReport::new(
            &self.scene,
            &self.run_id,
            report::Inputs {
                transport: seam_transport::redact_url(&self.transport),
                keyed: plan.key.is_some(),
                planned: self.server.faults(),
                rate: plan.rate,
                duration_s: plan.duration.as_secs_f64(),
                wall_s: self.launched.elapsed().as_secs_f64(),
                faults: self.faults,
                failed_faults: std::mem::take(&mut self.failed_faults),
                injected: self.injector.counts(),
                reports: &reports,
                dead_incarnations: &self.dead_incarnations,
                panics: self.pods.panics.load(Ordering::Relaxed),
                exited_badly,
                problems: std::mem::take(&mut self.problems),
                memory,
                fault_log: std::mem::take(&mut self.fault_log),
                accounting_slips: std::mem::take(&mut self.accounting_slips),
                by_name,
                owners,
            },
        ))
    }
}
