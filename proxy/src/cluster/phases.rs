//! [`PhaseCpu`]: the CPU time this pod's thread spent in each phase of a tick, measured when
//! asked ([`Cluster::time_phases`]): where a pod's work goes, apart from waiting for its
//! neighbours or for a core another process holds.

use serde::Serialize;

use super::Cluster;
use crate::clock::thread_cpu_ns;

/// The phases of a tick, in the order they run (see `cluster/tick.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Phase {
    /// Taking frames off the transport and checking them: between ticks and at a tick's
    /// start.
    Receive,
    /// The neighbours' replication frames brought in (proxies, hand-offs), the claim kept,
    /// neighbours taken for dead and their bodies adopted.
    Reconcile,
    /// Contact reports surfaced, then game code.
    User,
    /// Impulses at the seam settled, answers taken, routed ops applied, resends.
    Settle,
    /// Routed ops sent to their owners and theirs applied before the step.
    Exchange,
    /// Proxies a body here may touch made dynamic for the step.
    Couple,
    /// Rapier's step.
    Step,
    /// Contacts with proxies and seam impulses reported.
    Report,
    /// The authority policy asked; replication and events frames encoded and published.
    Publish,
}

impl Phase {
    /// Every phase, in order.
    pub const ALL: [Phase; 9] = [
        Phase::Receive,
        Phase::Reconcile,
        Phase::User,
        Phase::Settle,
        Phase::Exchange,
        Phase::Couple,
        Phase::Step,
        Phase::Report,
        Phase::Publish,
    ];

    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Receive => "receive",
            Phase::Reconcile => "reconcile",
            Phase::User => "user",
            Phase::Settle => "settle",
            Phase::Exchange => "exchange",
            Phase::Couple => "couple",
            Phase::Step => "step",
            Phase::Report => "report",
            Phase::Publish => "publish",
        }
    }
}

/// Thread CPU time of one tick by phase, ns.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct PhaseCpu([u64; Phase::ALL.len()]);

impl PhaseCpu {
    /// The time in `phase`, ns.
    pub fn get(&self, phase: Phase) -> u64 {
        self.0[phase as usize]
    }

    /// Every phase with its time, in order.
    pub fn iter(&self) -> impl Iterator<Item = (Phase, u64)> + '_ {
        Phase::ALL.into_iter().map(|p| (p, self.get(p)))
    }

    /// The whole tick's, ns.
    pub fn total(&self) -> u64 {
        self.0.iter().sum()
    }
}

/// Reads the thread's CPU clock at each phase's end, when on.
#[derive(Debug, Default)]
pub(crate) struct PhaseClock {
    on: bool,
    /// The clock at the last phase's end.
    last: u64,
    /// The tick under way (and what was received since the last one).
    current: PhaseCpu,
    /// The last tick finished.
    finished: PhaseCpu,
}

impl PhaseClock {
    /// A tick begins: phases count from now.
    pub(crate) fn start(&mut self) {
        if self.on {
            self.last = thread_cpu_ns();
        }
    }

    /// `phase` ended now.
    pub(crate) fn lap(&mut self, phase: Phase) {
        if self.on {
            let now = thread_cpu_ns();
            self.current.0[phase as usize] += now.saturating_sub(self.last);
            self.last = now;
        }
    }

    /// The clock now, when on (to time work between ticks with [`PhaseClock::add_since`]).
    pub(crate) fn now(&self) -> Option<u64> {
        self.on.then(thread_cpu_ns)
    }

    /// Adds the time from `since` (a [`PhaseClock::now`]) to now to `phase` of the next tick.
    pub(crate) fn add_since(&mut self, phase: Phase, since: Option<u64>) {
        if let Some(since) = since {
            self.current.0[phase as usize] += thread_cpu_ns().saturating_sub(since);
        }
    }

    /// The tick ended.
    pub(crate) fn finish(&mut self) {
        if self.on {
            self.finished = std::mem::take(&mut self.current);
        }
    }
}

impl Cluster {
    /// Measures the thread CPU time of every phase of each tick from now on (`true`), or stops
    /// (a few reads of the thread's CPU clock a tick, a system call each). Read with
    /// [`Cluster::phase_cpu`].
    pub fn time_phases(&mut self, on: bool) {
        self.phases = PhaseClock {
            on,
            ..PhaseClock::default()
        };
    }

    /// The thread CPU time of each phase of the last tick, ns (zeros unless
    /// [`Cluster::time_phases`] is on). Frames received between two ticks count in the
    /// second's `receive`.
    pub fn phase_cpu(&self) -> PhaseCpu {
        self.phases.finished
    }
}
