//! Running one cluster free: a tick on a fixed schedule of the host's monotonic clock.
//!
//! A pod — one cluster in its own process, on shared memory or Redis — ticks when its tick is
//! due and sleeps on its transport in between ([`Cluster::wait`]), so frames are taken in as
//! they arrive and an idle pod uses no CPU. Tick `k` is due at `anchor + k · period`: pods given
//! the same anchor (a `CLOCK_MONOTONIC` time, see [`monotonic_ns`]) tick in phase, and a pod
//! that fell behind runs its late ticks back to back until it has caught up. The last
//! [`DRAIN_S`] of a run start no policy hand-offs ([`Cluster::stop_policy_handoffs`]), so every
//! hand-off under way is taken before the pods stop.
//!
//! ```no_run
//! use std::sync::atomic::AtomicBool;
//! use seam_proxy::prelude::*;
//!
//! # fn game(_: &TickContext<'_>, _: &mut PhysicsHandle<'_>) {}
//! # fn main() -> Result<(), ClusterError> {
//! # let config = ClusterConfig::new(ClusterId::random(), vec![], "shm");
//! let mut cluster = Cluster::new(config)?;
//! let stop = AtomicBool::new(false); // set it from a signal handler to end the run early
//! let mut schedule = Schedule::new(60.0, 600)?; // 60 Hz, 600 ticks, tick 0 now
//! while let Some(_due) = schedule.wait_for_next(&mut cluster, &stop)? {
//!     cluster.tick(game)?;
//! }
//! # Ok(())
//! # }
//! ```

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crate::clock::monotonic_ns;
use crate::cluster::{Cluster, DRAIN_S};
use crate::error::ClusterError;

/// Ticks before the last that a cluster running as fast as it can (no period) stops the
/// policy's hand-offs.
pub const DRAIN_TICKS_UNSCHEDULED: u64 = 30;

/// A tick that is due.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Due {
    /// Its number (ticks run before it, counted from the world's tick 0).
    pub tick: u64,
    /// How long after its due time it starts, ns: more than a period means the pod is
    /// catching up.
    pub lag_ns: u64,
}

/// When each tick of a free-running cluster is due (see the module).
#[derive(Debug, Clone)]
pub struct Schedule {
    anchor_ns: u64,
    period_ns: Option<u64>,
    ticks: u64,
    next: u64,
    drain_ticks: u64,
    draining: bool,
}

impl Schedule {
    /// `rate_hz` ticks a second (0: as fast as the cluster can), `ticks` in all, tick 0 due
    /// now. An error for a rate that is negative or not a number.
    pub fn new(rate_hz: f64, ticks: u64) -> Result<Self, ClusterError> {
        if !(rate_hz.is_finite() && rate_hz >= 0.0) {
            return Err(ClusterError::Schedule(format!(
                "the tick rate must be 0 (as fast as it can) or positive, not {rate_hz}"
            )));
        }
        let period_ns = (rate_hz > 0.0).then(|| (1e9 / rate_hz) as u64);
        Ok(Self {
            anchor_ns: monotonic_ns(),
            period_ns,
            ticks,
            next: 0,
            drain_ticks: if rate_hz > 0.0 {
                (DRAIN_S * rate_hz).ceil() as u64
            } else {
                DRAIN_TICKS_UNSCHEDULED
            },
            draining: false,
        })
    }

    /// Tick 0 due at `anchor_ns` on `CLOCK_MONOTONIC` instead of now: pods of one run given
    /// the same anchor tick in phase. An anchor in the future is waited for; from one in the
    /// past, the ticks already due run back to back until the cluster has caught up (a pod
    /// joining a run under way skips them instead: [`Schedule::join`]).
    pub fn starting_at(mut self, anchor_ns: u64) -> Self {
        self.anchor_ns = anchor_ns;
        self
    }

    /// Joins a world already running on this schedule (a pod restarted after a crash): skips
    /// to the tick the schedule is at now and sets the cluster's tick count to it
    /// ([`Cluster::resume_at`]). Returns that tick. Without a period (as fast as it can) there
    /// is no schedule to join, and it starts at 0.
    pub fn join(&mut self, cluster: &mut Cluster) -> u64 {
        let now = monotonic_ns();
        if let Some(period) = self.period_ns
            && now > self.anchor_ns
        {
            self.next = ((now - self.anchor_ns) / period + 1).min(self.ticks);
            cluster.resume_at(self.next);
        }
        self.next
    }

    /// The period, ns (`None`: as fast as the cluster can).
    pub fn period_ns(&self) -> Option<u64> {
        self.period_ns
    }

    /// The next tick to run; once every tick has run, the planned count.
    pub fn next_tick(&self) -> u64 {
        self.next
    }

    /// Ticks planned in all.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }

    /// Sleeps on `cluster`'s transport, taking frames in as they arrive, until the next tick
    /// is due, and returns it; `None` once every planned tick has been handed out or `stop`
    /// is set (checked while waiting too). Entering the last [`DRAIN_S`] of the run, it stops
    /// the cluster's policy hand-offs.
    pub fn wait_for_next(
        &mut self,
        cluster: &mut Cluster,
        stop: &AtomicBool,
    ) -> Result<Option<Due>, ClusterError> {
        if self.next >= self.ticks || stop.load(Ordering::Relaxed) {
            return Ok(None);
        }
        if !self.draining && self.next + self.drain_ticks >= self.ticks {
            cluster.stop_policy_handoffs();
            self.draining = true;
        }
        let due = self.anchor_ns + self.period_ns.map_or(0, |p| self.next * p);
        let lag_ns = loop {
            let now = monotonic_ns();
            if now >= due {
                break now - due;
            }
            if stop.load(Ordering::Relaxed) {
                return Ok(None);
            }
            cluster.wait(Duration::from_nanos(due - now))?;
        };
        let tick = self.next;
        self.next += 1;
        Ok(Some(Due { tick, lag_ns }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rate_must_be_a_number_not_below_zero() {
        for rate in [-1.0, f64::NAN, f64::INFINITY] {
            let error = Schedule::new(rate, 10).expect_err("refused");
            assert!(error.to_string().contains("tick rate"), "{error}");
        }
        assert_eq!(Schedule::new(0.0, 10).expect("fine").period_ns(), None);
        assert_eq!(
            Schedule::new(50.0, 10).expect("fine").period_ns(),
            Some(20_000_000)
        );
    }
}
