//! [`Events`]: the stream every part of a cluster emits on.

use super::event::ClusterEvent;
use super::stats::ClusterStats;

/// Events kept between two `Cluster::take_events` calls at most; more are counted in
/// [`ClusterStats::events_dropped`].
pub const MAX_EVENTS: usize = 1 << 20;

/// An event with the cluster's tick when it happened ([`seam_sim::ClusterSim::tick`]: the
/// steps taken so far).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TickEvent {
    /// The tick.
    pub tick: u64,
    /// What happened.
    pub event: ClusterEvent,
}

/// The stream: every event is counted, and kept when asked for.
#[derive(Debug, Default)]
pub(crate) struct Events {
    /// The world's tick, stamped on each event kept.
    tick: u64,
    stats: ClusterStats,
    kept: Option<Vec<TickEvent>>,
}

impl Events {
    /// Emits one event.
    pub(crate) fn emit(&mut self, event: ClusterEvent) {
        self.stats.count(&event);
        if let Some(kept) = &mut self.kept {
            if kept.len() < MAX_EVENTS {
                kept.push(TickEvent {
                    tick: self.tick,
                    event,
                });
            } else {
                self.stats.events_dropped += 1;
            }
        }
    }

    /// Stamps the events from now on with `tick` (call whenever the world's tick changes).
    pub(crate) fn at_tick(&mut self, tick: u64) {
        self.tick = tick;
    }

    /// The counters.
    pub(crate) fn stats(&self) -> ClusterStats {
        self.stats
    }

    /// Keeps the events from now on.
    pub(crate) fn keep(&mut self) {
        self.kept.get_or_insert_with(Vec::new);
    }

    /// Takes the events kept since the last call.
    pub(crate) fn take(&mut self) -> Vec<TickEvent> {
        self.kept.as_mut().map(std::mem::take).unwrap_or_default()
    }
}
