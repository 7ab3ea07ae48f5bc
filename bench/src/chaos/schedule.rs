//! When faults come and which: the kinds in turn, the pod each hits, the instants that bound
//! them, and the phase a run is in between them.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// A pod is dead this long before it is started again.
pub(super) const KILLED_FOR: Duration = Duration::from_secs(2);
/// A pod is stopped this long.
pub(super) const STOPPED_FOR: Duration = Duration::from_secs(1);
/// Every pod shows progress again within this long of a fault's end, or it is not survived.
pub(super) const SURVIVE_WITHIN: Duration = Duration::from_secs(5);
/// Time the run may take beyond its planned length before its pods are killed and it fails:
/// pods catch up after a stop on their shared schedule, so a healthy run ends within seconds.
const DEADLINE_SLACK: Duration = Duration::from_secs(60);

/// A fault, and what it waits for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fault {
    Kill,
    Stop,
    RestartRedis,
    /// A Redis Cluster primary killed, started again a few seconds later.
    KillPrimary,
    /// The slot of a live channel moved to another Redis Cluster primary.
    MoveSlot,
}

/// Where a run is between faults.
#[derive(Debug, Clone, Copy)]
pub(super) enum Phase {
    /// Between faults; the next one is due at the instant.
    Calm(Instant),
    /// Pod `index` is dead until the instant.
    Killed(usize, Instant),
    /// Pod `index` is stopped until the instant.
    Stopped(usize, Instant),
    /// The Redis server (or a Redis Cluster primary) is down until the instant.
    RedisDown(Instant),
}

/// The faults of one run: their kinds in turn, a seeded choice of pod, and when they may come.
pub(super) struct Schedule {
    rng: u64,
    kinds: VecDeque<Fault>,
    /// The first fault is due here.
    pub(super) first_fault: Instant,
    /// No fault starts after this (so the run ends calm).
    pub(super) last_fault_by: Instant,
    /// No kill starts after this (every pod's last life lives at least half the run).
    kills_until: Instant,
    /// Pods still running after this are killed and the run fails.
    pub(super) deadline: Instant,
}

impl Schedule {
    /// The schedule of a run launched at `launched` whose pods start `start_delay` later and
    /// run for `duration`, a fault every `fault_every`, `kinds` in turn.
    pub(super) fn new(
        launched: Instant,
        start_delay: Duration,
        duration: Duration,
        fault_every: Duration,
        kinds: Vec<Fault>,
        seed: u64,
    ) -> Self {
        let started = launched + start_delay;
        Self {
            rng: seed.max(1),
            kinds: VecDeque::from(kinds),
            first_fault: started + fault_every,
            last_fault_by: started
                + duration.saturating_sub(KILLED_FOR + SURVIVE_WITHIN + Duration::from_secs(2)),
            kills_until: started + duration / 2,
            deadline: started + duration + DEADLINE_SLACK,
        }
    }

    /// A pseudo-random index below `bound`.
    pub(super) fn pick(&mut self, bound: usize) -> usize {
        self.rng = self
            .rng
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.rng >> 33) as usize) % bound.max(1)
    }

    /// The next kind in turn for a fault at `now`: a kill is skipped after half-time.
    pub(super) fn next_kind(&mut self, now: Instant) -> Fault {
        let mut fault = self.kinds[0];
        self.kinds.rotate_left(1);
        if fault == Fault::Kill && now >= self.kills_until {
            fault = self.kinds[0];
            self.kinds.rotate_left(1);
        }
        fault
    }
}
