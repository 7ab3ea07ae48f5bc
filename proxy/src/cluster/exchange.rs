//! The exchange before the step (`ClusterConfig::exchange`): each cluster sends every
//! neighbour, after game code and before its step, the ops it wrote on that neighbour's
//! entities and the impulses it gave its own bodies; each applies the ops it receives and
//! shows the impulses on its coupled proxies, then steps. So a push routed to another owner
//! acts in the step it was written in, as it would in one world, rather than a tick later.
//!
//! In lock-step a cluster waits for every neighbour's exchange frame of the tick (so one
//! process stepping several clusters runs each tick in two halves: [`Cluster::begin_lockstep`]
//! for all, then [`Cluster::finish_lockstep`]). Free-running, the exchange makes a tick a
//! barrier between neighbours that tick in phase, so a tick waits, at most
//! `neighbour_wait_ticks`, for each live neighbour exchanging in step with it twice: at its
//! start for the neighbour's frames of the step before (so it sees that step as lock-step
//! does), and before its step for the neighbour's exchange frame. A neighbour that misses is
//! counted (`ClusterStats::steps_missed`, `exchanges_missed`) and what it sends used when it
//! comes (its ops applied at the next tick, caught up as without the exchange).

use std::time::{Duration, Instant};

use seam_sim::wire::{ClusterId, PhysicsEventsFrame, Stage};

use super::Cluster;
use crate::clock::monotonic_ns;
use crate::error::ClusterError;
use crate::events::ClusterEvent;
use crate::inbox::{FrameKind, decode_frame};
use crate::neighbours::Neighbours;
use crate::routing::Owner;

impl Cluster {
    /// Sends each neighbour this tick's exchange frame: the ops queued for it so far and the
    /// impulses game code gave this cluster's own bodies.
    pub(super) fn send_exchange(&mut self) -> Result<(), ClusterError> {
        if !self.config.exchange {
            return Ok(());
        }
        let (me, tick) = (self.config.cluster_id, self.sim.tick());
        for i in 0..self.config.neighbours.len() {
            let neighbour = self.config.neighbours[i];
            let gone = self.neighbours.is_gone(neighbour);
            let mut frame = PhysicsEventsFrame::empty(me, tick, Stage::BeforeStep, monotonic_ns());
            frame.incarnation = self.incarnation;
            frame.ops = self
                .routing
                .send(me, neighbour, tick, &self.retry, gone, &mut self.events);
            frame.own_writes = self.routing.own_writes().to_vec();
            self.publish_events_frame(neighbour, &frame)?;
        }
        Ok(())
    }

    /// Lock-step: waits (up to `timeout`) until every neighbour's exchange frame of this tick
    /// is in.
    pub(super) fn wait_exchange_lockstep(&mut self, timeout: Duration) -> Result<(), ClusterError> {
        if !self.config.exchange {
            return Ok(());
        }
        let tick = self.sim.tick();
        let deadline = Instant::now() + timeout;
        loop {
            self.drain()?;
            let Some(&neighbour) = self
                .config
                .neighbours
                .iter()
                .find(|&&n| !self.inbox.has_exchange(tick, n))
            else {
                return Ok(());
            };
            let now = Instant::now();
            if now >= deadline {
                return Err(ClusterError::NeighbourSilent {
                    neighbour,
                    what: "physics_events (before the step)",
                    tick,
                    waited_ms: timeout.as_millis() as u64,
                });
            }
            self.receive_one(deadline - now)?;
        }
    }

    /// Free-running: waits, at most `neighbour_wait_ticks`, for the frames of the step that
    /// reached this tick of each live neighbour exchanging in step; counts those that miss.
    /// Notes whether the tick starts as a lock-step tick would: every live neighbour in step,
    /// its frames of the step before in.
    pub(super) fn wait_step_free(&mut self) -> Result<(), ClusterError> {
        let tick = self.sim.tick();
        let replication = tick.is_multiple_of(self.config.replication_interval.max(1));
        self.in_step = self.wait_in_step(
            |heard, n| {
                heard.has_heard(n, FrameKind::Events, tick)
                    && (!replication || heard.has_heard(n, FrameKind::Replication, tick))
            },
            |neighbour| ClusterEvent::StepMissed { neighbour },
        )?;
        Ok(())
    }

    /// Free-running: waits, at most `neighbour_wait_ticks`, for the exchange frame of this tick
    /// of each live neighbour exchanging in step; counts those that miss it.
    pub(super) fn wait_exchange_free(&mut self) -> Result<(), ClusterError> {
        let tick = self.sim.tick();
        self.wait_in_step(
            |heard, n| heard.has_heard(n, FrameKind::Exchange, tick),
            |neighbour| ClusterEvent::ExchangeMissed { neighbour },
        )
        .map(|_| ())
    }

    /// Waits, at most `neighbour_wait_ticks` (and not at all without the exchange), until
    /// `has(neighbours, neighbour)` holds for each live neighbour exchanging in step with this
    /// cluster; emits `missed(neighbour)` for each it does not hold for then. What has been
    /// heard is asked of [`Neighbours`], not the inbox: a frame that came early was taken by
    /// an earlier tick. Returns whether every live neighbour is in step and had it.
    fn wait_in_step(
        &mut self,
        has: impl Fn(&Neighbours, ClusterId) -> bool,
        missed: impl Fn(ClusterId) -> ClusterEvent,
    ) -> Result<bool, ClusterError> {
        if !self.config.exchange {
            return Ok(false);
        }
        let tick = self.sim.tick();
        let config = &self.config;
        if !config
            .neighbours
            .iter()
            .any(|&n| self.neighbours.exchanges_in_step(n, tick))
        {
            // Nobody to wait for: frames stay on the transport for the next tick's start.
            return Ok(self.neighbours.all_alive_in_step(tick));
        }
        let wait = f64::from(self.config.neighbour_wait_ticks.max(0.0) * self.config.dt);
        let deadline = Instant::now() + Duration::from_secs_f64(wait);
        loop {
            self.drain()?;
            let missing: Vec<ClusterId> = self
                .config
                .neighbours
                .iter()
                .copied()
                .filter(|&n| {
                    self.neighbours.exchanges_in_step(n, tick) && !has(&self.neighbours, n)
                })
                .collect();
            let now = Instant::now();
            if missing.is_empty() {
                return Ok(self.neighbours.all_alive_in_step(tick));
            }
            if now >= deadline {
                for neighbour in missing {
                    self.events.emit(missed(neighbour));
                }
                return Ok(false);
            }
            self.receive_one(deadline - now)?;
        }
    }

    /// Sleeps on the transport up to `timeout` for one message, and takes it in.
    pub(super) fn receive_one(&mut self, timeout: Duration) -> Result<(), ClusterError> {
        if let Some(message) = self.transport.receive_timeout(timeout)? {
            let received_ns = monotonic_ns();
            let frame = decode_frame(&message);
            self.take_in(frame, received_ns);
        }
        Ok(())
    }

    /// The neighbours' exchange frames of this tick and before: their ops applied (or
    /// forwarded, or answered "not here") just before the step, and the impulses they gave
    /// their own bodies this tick noted for this world's coupled proxies of them.
    pub(super) fn apply_exchanged(&mut self) {
        let tick = self.sim.tick();
        let frames = self
            .inbox
            .take_exchange(tick, &self.config.neighbours, self.free_running);
        if frames.is_empty() {
            return;
        }
        let mut owner = Owner {
            sim: &mut self.sim,
            config: &self.config,
            neighbours: &self.neighbours,
            custody: &self.custody,
            receipts: &mut self.receipts,
            events: &mut self.events,
        };
        self.routing.apply_received(&frames, tick, &mut owner);
        if !self.config.coupling {
            return;
        }
        for (frame, _) in frames.iter().filter(|(frame, _)| frame.tick == tick) {
            let (shown, rejected): (Vec<_>, Vec<_>) =
                frame.own_writes.iter().copied().partition(|op| {
                    op.vector().is_some_and(|v| {
                        v.iter().all(|c| c.is_finite()) && self.config.within_bound(v)
                    })
                });
            for _ in &rejected {
                self.events
                    .emit(ClusterEvent::OwnWriteRejected { from: frame.from });
            }
            self.predictions.neighbour_wrote(&shown, tick);
        }
    }
}
