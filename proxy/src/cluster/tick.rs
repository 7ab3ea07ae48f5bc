//! Running a tick: free-running ([`Cluster::tick`], [`Cluster::wait`]) or in lock-step
//! ([`Cluster::tick_lockstep`], or its two halves), and `run_until_exchange` and
//! `finish_tick`, the phases every tick runs in order.

use std::time::{Duration, Instant};

use seam_sim::{PhysicsHandle, TickContext};

use super::{Cluster, Phase};
use crate::clock::monotonic_ns;
use crate::contacts::HALF_WAITS_TICKS;
use crate::error::ClusterError;
use crate::events::ClusterEvent;
use crate::handoff;
use crate::inbox::{HeldReplication, TickFrames, decode_frame};
use crate::replication::Reconcile;
use crate::routing::Owner;

/// Physics-events frames of one tick, with the time each was received.
type EventsFrames = [(seam_sim::wire::PhysicsEventsFrame, u64)];

impl Cluster {
    /// One tick using whatever has arrived (free-running pods). A neighbour silent for more
    /// than `neighbour_timeout_ticks` is taken for dead first (see
    /// [`NeighbourStatus`](crate::NeighbourStatus)). The same as [`Cluster::tick_at`] at the
    /// host's monotonic time now.
    pub fn tick(
        &mut self,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        self.tick_at(monotonic_ns(), user)
    }

    /// [`Cluster::tick`] with the host time given, in [`monotonic_ns`] nanoseconds: a
    /// neighbour is taken for dead only once it has been silent for `neighbour_timeout_ticks`
    /// ticks *and* that many `dt` of this clock, so a pod catching up after a stall (ticks back
    /// to back) does not take its neighbours for dead. Frames taken in since the last tick
    /// count as heard at `now_ns`. Tests drive this clock by hand instead of sleeping.
    pub fn tick_at(
        &mut self,
        now_ns: u64,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        self.free_running = true;
        self.phases.start();
        self.note_host_time(now_ns);
        self.drain()?;
        if self.sim.tick() == 0 {
            self.start_free()?;
        }
        self.wait_step_free()?;
        self.check_liveness();
        let frames = self.inbox.take_all(self.sim.tick());
        self.run_until_exchange(frames, user)?;
        self.wait_exchange_free()?;
        self.finish_tick()
    }

    /// One tick in lock-step: waits (up to `timeout`) until every neighbour's frames from the
    /// same tick have arrived, and uses exactly those, so runs are deterministic on any
    /// transport. With the exchange (`ClusterConfig::exchange`, on by default) it also waits,
    /// before stepping, for every neighbour's ops of this tick, so the neighbours must be
    /// ticking at the same time (other threads or processes); one thread stepping several
    /// clusters calls [`Cluster::begin_lockstep`] on each, then [`Cluster::finish_lockstep`]
    /// on each (as [`lockstep_round`](crate::lockstep_round) does).
    pub fn tick_lockstep(
        &mut self,
        timeout: Duration,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        self.begin_lockstep(timeout, user)?;
        self.finish_lockstep(timeout)
    }

    /// The first half of a lock-step tick: waits (up to `timeout`) for the neighbours' frames
    /// of the previous step, runs every phase up to game code and the routing after it, and
    /// sends the exchange frames. [`Cluster::finish_lockstep`] runs the rest.
    pub fn begin_lockstep(
        &mut self,
        timeout: Duration,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        if self.begun {
            return Err(ClusterError::TickOrder(
                "begin_lockstep called again before finish_lockstep",
            ));
        }
        self.free_running = false;
        self.phases.start();
        self.host_ns = monotonic_ns();
        let tick = self.sim.tick();
        if tick == 0 {
            // The world as it starts, out before any step; taken in before this world's
            // first step (`finish_lockstep`), when every neighbour has begun too.
            self.publish()?;
            return self.run_until_exchange(TickFrames::default(), user);
        }
        self.wait_for_tick(tick, timeout)?;
        let frames = self.inbox.take_tick(tick, &self.config.neighbours);
        self.run_until_exchange(frames, user)
    }

    /// The second half of a lock-step tick: waits (up to `timeout`) for every neighbour's
    /// exchange frame of this tick, applies their ops, steps and publishes.
    pub fn finish_lockstep(&mut self, timeout: Duration) -> Result<(), ClusterError> {
        if !self.begun {
            return Err(ClusterError::TickOrder(
                "finish_lockstep called without begin_lockstep",
            ));
        }
        self.wait_exchange_lockstep(timeout)?;
        if self.sim.tick() == 0 {
            self.take_start(timeout)?;
        }
        self.finish_tick()
    }

    /// Waits (up to `timeout`) until every neighbour's frames tagged `tick` are in.
    pub(super) fn wait_for_tick(
        &mut self,
        tick: u64,
        timeout: Duration,
    ) -> Result<(), ClusterError> {
        let replication = tick.is_multiple_of(self.config.replication_interval);
        let deadline = Instant::now() + timeout;
        self.drain()?;
        while let Some((neighbour, what)) =
            self.inbox
                .missing(tick, &self.config.neighbours, replication)
        {
            let now = Instant::now();
            if now >= deadline {
                return Err(ClusterError::NeighbourSilent {
                    neighbour,
                    what,
                    tick,
                    waited_ms: timeout.as_millis() as u64,
                });
            }
            if let Some(message) = self.transport.receive_timeout(deadline - now)? {
                let received_ns = monotonic_ns();
                let frame = decode_frame(&message);
                self.take_in(frame, received_ns);
            }
            self.drain()?;
        }
        Ok(())
    }

    /// A tick on the frames the caller gathered, every phase in order up to the exchange (the
    /// caller then waits for the neighbours' exchange frames and calls `finish_tick`).
    fn run_until_exchange(
        &mut self,
        frames: TickFrames,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        self.begun = true;
        self.phases.lap(Phase::Receive);
        self.keep_claim()?;
        self.handoffs.new_tick();
        self.reconcile(frames.replication);
        handoff::return_overdue(
            &mut self.handoffs,
            &mut self.sim,
            &self.config,
            &mut self.events,
        );
        self.take_leaving(&frames.events);
        self.phases.lap(Phase::Reconcile);
        self.surface_contacts(&frames.events);
        self.run_user(user);
        self.phases.lap(Phase::User);
        self.settle_seam(&frames.events);
        self.take_answers(&frames.events);
        self.apply_routed(&frames.events);
        self.resend_due();
        self.phases.lap(Phase::Settle);
        self.send_exchange()
    }

    /// The rest of the tick, from the neighbours' exchanged ops to the frames out.
    fn finish_tick(&mut self) -> Result<(), ClusterError> {
        self.begun = false;
        self.apply_exchanged();
        self.phases.lap(Phase::Exchange);
        self.couple();
        self.phases.lap(Phase::Couple);
        self.step();
        self.phases.lap(Phase::Step);
        self.report();
        self.phases.lap(Phase::Report);
        self.publish()?;
        self.warn_dropped_ops();
        self.phases.lap(Phase::Publish);
        self.phases.finish();
        self.events.emit(ClusterEvent::Ticked);
        Ok(())
    }

    /// Takes neighbours silent for too long for dead: adopts what the rule gives this cluster
    /// of their entities, despawns the rest of their proxies.
    fn check_liveness(&mut self) {
        let transport = &self.transport;
        let dead = self
            .neighbours
            .find_dead(&self.config, self.sim.tick(), self.host_ns, || {
                transport.is_connected()
            });
        for neighbour in dead {
            self.events.emit(ClusterEvent::NeighbourLost { neighbour });
            let adopted = self.stats().entities_adopted;
            self.custody.adopt_from(
                neighbour,
                &mut self.sim,
                &self.config,
                &self.neighbours,
                &mut self.handoffs,
                &mut self.events,
            );
            tracing::warn!(
                cluster = %self.config.label(self.config.cluster_id),
                neighbour = %self.config.label(neighbour),
                silent_ticks = self.config.neighbour_timeout_ticks,
                adopted = self.stats().entities_adopted - adopted,
                "neighbour taken for dead: its proxies despawned, its entities adopted"
            );
        }
    }

    /// Brings the world in line with the neighbours' frames (the hand-offs held for this tick
    /// first); each is kept as its sender's last picture (with a world map, to adopt from).
    pub(super) fn reconcile(&mut self, frames: Vec<HeldReplication>) {
        let (tick, config) = (self.sim.tick(), &self.config);
        self.interest.expire(tick);
        let mut reconcile = Reconcile {
            sim: &mut self.sim,
            config,
            events: &mut self.events,
            handoffs: &mut self.handoffs,
            interest: &self.interest,
            proxies: &mut self.proxies,
            predictions: &mut self.predictions,
            hold_until: self
                .free_running
                .then(|| self.catch_up.holds_until(tick, config)),
            yielded: Vec::new(),
        };
        reconcile.early_handoffs();
        let keep_last = !self.config.world.is_empty();
        for frame in frames {
            reconcile.frame(&frame);
            if keep_last {
                self.custody.keep_last(frame);
            }
        }
        let yielded = std::mem::take(&mut reconcile.yielded);
        self.custody.yielded(&yielded, &mut self.events);
    }

    /// Neighbours heard leaving last tick are taken as left (their last replication frame,
    /// on another channel, reconciled first): hand-offs to them that they never answered come
    /// back. Those leaving in `events` are taken as left next tick.
    fn take_leaving(&mut self, events: &EventsFrames) {
        let me = self.config.cluster_id;
        for neighbour in self.neighbours.take_leaving() {
            self.events.emit(ClusterEvent::NeighbourLeft { neighbour });
            for handed in self.handoffs.take_in_transit_to(neighbour) {
                if handoff::take_back(&mut self.sim, me, &handed) {
                    self.events.emit(ClusterEvent::HandoffTakenBack {
                        entity: handed.id,
                        from: neighbour,
                    });
                }
            }
            tracing::info!(
                cluster = %self.config.label(me),
                neighbour = %self.config.label(neighbour),
                "neighbour left: not waited for, nothing adopted from it"
            );
        }
        self.neighbours.hear_leaving(events);
        self.handoffs
            .hear_unmodelled(events, self.sim.tick(), &self.config);
    }

    /// This world's contacts of the last step and the neighbours' reports, each surfaced once.
    fn surface_contacts(&mut self, events: &EventsFrames) {
        self.reports.surface(
            events,
            &mut self.sim,
            &self.config,
            &self.custody,
            &mut self.receipts,
            &mut self.events,
        );
    }

    /// Game code; its writes on remote-owned entities go to the outbox, and the impulses
    /// among them are shown on this world's coupled proxies (see `crate::contacts`).
    fn run_user(&mut self, user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>)) {
        let tick = self.sim.tick();
        let mut outbox = self.routing.outbox(
            &mut self.numbers,
            &self.config.neighbours,
            tick,
            self.config.exchange && self.config.coupling,
        );
        self.sim.run_user(&mut outbox, user);
        if self.config.coupling {
            self.predictions.routed(self.routing.queued(), tick);
        }
    }

    /// Contacts across the seam settled (see `crate::contacts`); the pushes the other world
    /// did not see routed to their bodies' owners.
    fn settle_seam(&mut self, events: &EventsFrames) {
        // A free-running tick whose neighbours are all in step has their reports of the
        // step before, as a lock-step tick does.
        let wait = if self.free_running && !self.in_step {
            HALF_WAITS_TICKS
        } else {
            0
        };
        let unseen = self.seam.settle(
            events,
            wait,
            &mut self.sim,
            &self.config,
            &self.neighbours,
            &mut self.events,
        );
        let tick = self.sim.tick();
        for (owner, op) in unseen {
            self.routing.issue(owner, op, &mut self.numbers, tick);
        }
    }

    /// Answers to this cluster's ops and reports taken in.
    fn take_answers(&mut self, events: &EventsFrames) {
        let (me, tick) = (self.config.cluster_id, self.sim.tick());
        self.routing
            .take_answers(events, me, tick, &mut self.events);
        self.reports
            .take_answers(events, me, tick, &mut self.events);
    }

    /// The routed writes received, applied just before the step (or forwarded, or "not here").
    fn apply_routed(&mut self, events: &EventsFrames) {
        let tick = self.sim.tick();
        let mut owner = Owner {
            sim: &mut self.sim,
            config: &self.config,
            neighbours: &self.neighbours,
            custody: &self.custody,
            receipts: &mut self.receipts,
            events: &mut self.events,
        };
        self.routing.apply_received(events, tick, &mut owner);
    }

    /// This cluster's unanswered ops and reports that are due sent again (or applied, if
    /// their entity is this cluster's now).
    fn resend_due(&mut self) {
        let tick = self.sim.tick();
        let mut owner = Owner {
            sim: &mut self.sim,
            config: &self.config,
            neighbours: &self.neighbours,
            custody: &self.custody,
            receipts: &mut self.receipts,
            events: &mut self.events,
        };
        self.routing.resend_due(tick, &self.retry, &mut owner);
        self.reports.resend_due(
            tick,
            &self.retry,
            &self.sim,
            &self.config,
            &self.neighbours,
            &mut self.events,
        );
    }

    /// The world steps.
    fn step(&mut self) {
        self.sim.step();
        self.events.at_tick(self.sim.tick());
    }

    /// What the step did at the seam: contacts with proxies reported to their owners, and the
    /// impulses each contact gave this cluster's bodies.
    fn report(&mut self) {
        self.reports
            .report(&self.sim, &self.config, &mut self.numbers);
        self.seam.report(&self.sim, &self.config, &mut self.events);
    }
}
