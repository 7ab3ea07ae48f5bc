//! The pods of a chaos run ([`Pods`]): each pod's current process and what it said, every
//! life's ledger, and the lines their readers send.

use std::path::PathBuf;
use std::process::Child;
use std::sync::Arc;
use std::sync::atomic::AtomicU64;
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rustix::process::{Pid, Signal, kill_process};

use super::MemorySample;
use crate::error::{BenchError, BenchResult};
use crate::ledger::Life;
use crate::node::{NodeLine, NodeProgress, NodeReport};
use crate::run::{PodLaunch, PodLine, RunPlan, spawn_pod};

/// Every pod of a run, the lives they have lived, and the lines they send. Dropped, it leaves
/// no pod running.
pub(super) struct Pods {
    pub(super) all: Vec<PodState>,
    pub(super) readers: Vec<JoinHandle<()>>,
    pub(super) run_plan: RunPlan,
    pub(super) ticks: u64,
    /// Every life's ledger, in a directory of the run's own: removed at the end, unless they
    /// show an op or report lost or applied twice.
    pub(super) ledgers: Ledgers,
    pub(super) lives: Vec<Life>,
    pub(super) panics: Arc<AtomicU64>,
    lines: mpsc::Sender<PodLine>,
    incoming: mpsc::Receiver<PodLine>,
    /// When the run was launched (memory samples are timed from it).
    launched: Instant,
}

impl Pods {
    /// Launches one pod per name of `clusters`, each `ticks` ticks, the first at `start_at`
    /// (monotonic ns) and the others in phase with it or staggered, as `run_plan` says.
    pub(super) fn launch_all(
        run_plan: RunPlan,
        clusters: &[String],
        start_at: u64,
        ticks: u64,
        launched: Instant,
    ) -> BenchResult<Self> {
        let ledgers = Ledgers::new(&run_plan.run_id)?;
        let (lines, incoming) = mpsc::channel::<PodLine>();
        let n = clusters.len() as u64;
        let all = (clusters.iter().enumerate())
            .map(|(i, name)| PodState::new(name, start_at + run_plan.pod_offset_ns(i, n)))
            .collect();
        let mut pods = Self {
            all,
            readers: Vec::new(),
            run_plan,
            ticks,
            ledgers,
            lives: Vec::new(),
            panics: Arc::new(AtomicU64::new(0)),
            lines,
            incoming,
            launched,
        };
        for index in 0..clusters.len() {
            pods.launch(index, false)?;
        }
        Ok(pods)
    }

    /// Starts pod `index` (again, empty, if `rejoin`): a new life with a ledger of its own.
    pub(super) fn launch(&mut self, index: usize, rejoin: bool) -> BenchResult<()> {
        let pod = &mut self.all[index];
        let ledger = self.ledgers.path(&pod.name, self.lives.len());
        let (child, reader) = spawn_pod(
            &self.run_plan,
            &PodLaunch {
                index,
                cluster: &pod.name,
                start_at: pod.start_at,
                ticks: self.ticks,
                rejoin,
                panics: &self.panics,
                transport: None,
                namespace: None,
                ledger: Some(&ledger),
            },
            &self.lines,
        )?;
        self.readers.push(reader);
        pod.life = self.lives.len();
        self.lives.push(Life {
            path: ledger,
            killed_after: None,
            stopped: Vec::new(),
        });
        pod.child = Some(child);
        pod.latest = None;
        pod.memory.clear();
        Ok(())
    }

    /// Waits up to `wait` for a line and takes it; false when no reader is left.
    pub(super) fn receive(&mut self, wait: Duration, problems: &mut Vec<String>) -> bool {
        match self.incoming.recv_timeout(wait) {
            Ok(line) => self.take(line, problems),
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => return false,
        }
        true
    }

    /// Takes every line that comes with no more than `gap` between two.
    pub(super) fn drain_while_coming(&mut self, gap: Duration, problems: &mut Vec<String>) {
        while let Ok(line) = self.incoming.recv_timeout(gap) {
            self.take(line, problems);
        }
    }

    /// Takes every line that comes within `time`.
    pub(super) fn drain_for(&mut self, time: Duration, problems: &mut Vec<String>) {
        let until = Instant::now() + time;
        while let Some(left) = until.checked_duration_since(Instant::now()) {
            if let Ok(line) = self.incoming.recv_timeout(left) {
                self.take(line, problems);
            }
        }
    }

    /// Notes what a pod said: its progress (and memory), its report, or what was wrong.
    fn take(&mut self, (index, line): PodLine, problems: &mut Vec<String>) {
        match line {
            Ok(NodeLine::Progress(p)) => {
                let pod = &mut self.all[index];
                pod.memory.push(MemorySample {
                    at_s: self.launched.elapsed().as_secs_f64(),
                    rss_kib: p.rss_kib,
                    owned: p.entities_owned,
                });
                pod.latest = Some((Instant::now(), *p));
            }
            Ok(NodeLine::Report(r)) => self.all[index].report = Some(*r),
            Err(e) => problems.push(format!("pod {:?}: {e}", self.all[index].name)),
        }
    }

    /// Whether every pod has shown progress in its current life.
    pub(super) fn all_running(&self) -> bool {
        self.all.iter().all(|p| p.latest.is_some())
    }

    /// Whether every pod's current process has exited.
    pub(super) fn all_exited(&mut self) -> bool {
        self.all.iter_mut().all(PodState::exited)
    }
}

/// One pod: its current process and what it said.
pub(super) struct PodState {
    pub(super) name: String,
    pub(super) start_at: u64,
    pub(super) child: Option<Child>,
    pub(super) latest: Option<(Instant, NodeProgress)>,
    /// Memory samples of the current incarnation.
    pub(super) memory: Vec<MemorySample>,
    /// The current incarnation's place in the run's lives (its ledger).
    pub(super) life: usize,
    pub(super) report: Option<NodeReport>,
}

impl PodState {
    /// A pod not started yet, to start at `start_at` (monotonic ns).
    pub(super) fn new(name: &str, start_at: u64) -> Self {
        Self {
            name: name.to_owned(),
            start_at,
            child: None,
            latest: None,
            memory: Vec::new(),
            life: 0,
            report: None,
        }
    }

    /// Whether its current process has exited (false before it is started).
    pub(super) fn exited(&mut self) -> bool {
        match &mut self.child {
            Some(child) => matches!(child.try_wait(), Ok(Some(_))),
            None => false,
        }
    }

    /// Whether its current process still runs.
    pub(super) fn running(&mut self) -> bool {
        match &mut self.child {
            Some(child) => matches!(child.try_wait(), Ok(None)),
            None => false,
        }
    }

    /// Sends `sig` to its current process, if any.
    pub(super) fn signal(&self, sig: Signal) {
        if let Some(child) = &self.child {
            signal(child, sig);
        }
    }
}

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

pub(super) fn signal(child: &Child, signal: Signal) {
    if let Some(pid) = Pid::from_raw(child.id() as i32) {
        let _ = kill_process(pid, signal);
    }
}

/// The directory of the pods' ledgers: the run's own, removed when the run ends unless
/// `remove` is cleared.
pub(super) struct Ledgers {
    pub(super) dir: PathBuf,
    pub(super) remove: bool,
}

impl Ledgers {
    pub(super) fn new(run_id: &str) -> BenchResult<Self> {
        let dir = std::env::temp_dir().join(format!("seam-chaos-ledgers-{run_id}"));
        std::fs::create_dir_all(&dir).map_err(|e| {
            BenchError::io("create", format!("{} for the ledgers", dir.display()), e)
        })?;
        Ok(Self { dir, remove: true })
    }

    /// The ledger of life `life` (numbered across the run) of pod `name`.
    pub(super) fn path(&self, name: &str, life: usize) -> PathBuf {
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
