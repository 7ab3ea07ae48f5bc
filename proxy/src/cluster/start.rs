//! A world's first step: before it, every cluster sends its frames of the world as it starts
//! (tick 0) and takes its neighbours' in, so each world holds its proxies from the first step
//! as one world holds every body. Without them a body resting on a neighbour's fell freely
//! through that step, and two crates of two clusters stacked on a third's ended exactly
//! touching, a pose Rapier's contact between convex hulls can miss (docs/accuracy.md, "Stacks
//! at a corner: the first step").

use std::time::{Duration, Instant};

use seam_sim::wire::ClusterId;

use super::Cluster;
use crate::error::ClusterError;
use crate::inbox::FrameKind;

impl Cluster {
    /// Lock-step: the neighbours' frames of tick 0, sent as each began
    /// (`Cluster::begin_lockstep`), taken in before the first step, once every cluster has
    /// begun (waiting in `begin` would deadlock one thread driving every cluster).
    pub(super) fn take_start(&mut self, timeout: Duration) -> Result<(), ClusterError> {
        self.wait_for_tick(0, timeout)?;
        let frames = self.inbox.take_tick(0, &self.config.neighbours);
        self.reconcile(frames.replication);
        Ok(())
    }

    /// Free-running: sends this world's frames of tick 0, then waits, at most
    /// `neighbour_wait_ticks` as for any step's frames, until it has heard every neighbour's of
    /// tick 0 or later; the tick then takes what has arrived. Pods started on one anchor begin
    /// within that wait of each other; a neighbour not up yet is not waited for longer.
    pub(super) fn start_free(&mut self) -> Result<(), ClusterError> {
        self.publish()?;
        let wait = f64::from(self.config.neighbour_wait_ticks.max(0.0) * self.config.dt);
        let deadline = Instant::now() + Duration::from_secs_f64(wait);
        loop {
            self.drain()?;
            // Heard, not in the inbox: a neighbour that began first may have sent its next
            // frames already, and the inbox keeps a neighbour's newest.
            let neighbours = &self.neighbours;
            let heard = |n: &ClusterId| {
                neighbours.has_heard(*n, FrameKind::Replication, 0)
                    && neighbours.has_heard(*n, FrameKind::Events, 0)
            };
            let now = Instant::now();
            if now >= deadline || self.config.neighbours.iter().all(heard) {
                return Ok(());
            }
            self.receive_one(deadline - now)?;
        }
    }
}
