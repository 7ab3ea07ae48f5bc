//! This tick's frames out: the replication frame (after asking the authority policy), and one
//! physics-events frame per neighbour with its routed ops, answers, contacts and impulses.

use seam_sim::wire::{self, ClusterId, PhysicsEventsFrame, ReplicationFrame, Stage};

use super::{Cluster, EVENTS_ROOM};
use crate::authority::AuthorityView;
use crate::channels;
use crate::clock::monotonic_ns;
use crate::error::ClusterError;
use crate::events::ClusterEvent;
use crate::handoff;
use crate::replication::FrameHandoffs;

impl Cluster {
    /// Gets the transport ready to publish this cluster's frames, so the first tick does not
    /// pay for setting channels up (on shm: creating services and shared memory, milliseconds
    /// per channel). Call it after spawning the entities the cluster starts with: the
    /// replication channel gets room for a frame of them all, with a quarter to spare.
    pub fn advertise(&mut self) -> Result<(), ClusterError> {
        let me = self.id();
        let owned = self
            .sim
            .entities()
            .filter(|(_, info)| info.owner == me)
            .count();
        let frame = ReplicationFrame {
            from: me,
            tick: 0,
            incarnation: self.incarnation,
            states: Vec::new(),
        };
        let room = frame.max_encoded_len() + (owned + owned / 4) * wire::MAX_STATE_LEN;
        self.transport.advertise(self.publisher.channel(), room)?;
        for &neighbour in &self.config.neighbours {
            self.transport
                .advertise(&channels::physics_events(neighbour), EVENTS_ROOM)?;
        }
        Ok(())
    }

    /// Publishes this tick's replication frame (every `replication_interval` ticks, with any
    /// hand-offs) and one events frame per neighbour. A cluster alone in its world (no
    /// neighbours, no other cluster on the world map: a one-world server) publishes no
    /// replication: no cluster proxies its bodies or takes them over. One without neighbours
    /// in a larger world still does: a cluster it does not list may list it.
    pub(super) fn publish(&mut self) -> Result<(), ClusterError> {
        let tick = self.sim.tick();
        let me = self.config.cluster_id;
        let alone = self.config.neighbours.is_empty()
            && self.config.world.iter().all(|cluster| cluster.id == me);
        if tick.is_multiple_of(self.config.replication_interval) && !alone {
            self.publish_replication(tick)?;
        }
        for i in 0..self.config.neighbours.len() {
            let neighbour = self.config.neighbours[i];
            self.publish_events(neighbour, tick)?;
        }
        Ok(())
    }

    /// The replication frame: the owned states, with the hand-offs the policy and game code
    /// asked for; the bodies handed over become proxies.
    ///
    /// While this cluster's transport is down (a Redis outage, or a Redis Cluster shard it
    /// uses without a primary) nothing is handed over, by the policy or by queued hand-offs:
    /// the frame that hands a body would reach nobody, and the body would be nobody's until
    /// the hand-off came back. They wait for the transport. So do those of a frame the
    /// transport dropped as it found its server gone (a primary killed between two ticks).
    fn publish_replication(&mut self, tick: u64) -> Result<(), ClusterError> {
        let up = self.transport.is_connected();
        let dropped_before = self.transport.stats().dropped_while_down;
        if up {
            self.ask_policy();
        } else {
            self.publisher.gather(&self.sim, self.config.cluster_id);
        }
        let handing = self.publisher.publish(
            self.transport.as_mut(),
            &self.config,
            tick,
            FrameHandoffs {
                handoffs: &self.handoffs,
                held: !up,
            },
            &mut self.interest,
            &mut self.events,
        )?;
        if self.transport.stats().dropped_while_down > dropped_before {
            return Ok(());
        }
        for handed in &handing {
            self.custody.release(handed.id);
        }
        self.handoffs.given(
            handing,
            tick,
            self.config.proxy_mode,
            &mut self.sim,
            &mut self.events,
        )
    }

    /// Gathers this frame's owned states and asks the authority policy which of them to hand
    /// over; queues those hand-offs that are valid and not already queued by game code.
    /// Adopted entities stay in custody until their owner returns and gets them back.
    fn ask_policy(&mut self) {
        let me = self.config.cluster_id;
        let owned = self.publisher.gather(&self.sim, me);
        let Some(policy) = self.policy.as_mut() else {
            return;
        };
        let neighbours = self.neighbours.views(&self.config);
        let budget = policy.touching_budget(self.config.clusters_known());
        let touching = if budget > 0 && !neighbours.is_empty() {
            self.sim.touching(budget)
        } else {
            Vec::new()
        };
        let custody: Vec<_>;
        let owned = if self.custody.is_empty() {
            owned
        } else {
            custody = owned
                .iter()
                .filter(|(state, _)| self.custody.adopted_from(state.id).is_none())
                .copied()
                .collect();
            &custody
        };
        let view = AuthorityView {
            cluster: me,
            tick: self.sim.tick(),
            region: self.config.region,
            lookahead_s: self.config.dt * self.config.replication_interval.max(1) as f32,
            neighbours: &neighbours,
            owned,
            touching: &touching,
        };
        let mut handoffs = Vec::new();
        policy.decide(&view, &mut handoffs);
        for (entity, to) in handoffs {
            // Held for a neighbour taken for dead until it is back (a policy may name one as
            // a member of a group it sees in contact, not from `owned`).
            // Nor handed where it was declined lately (its hand-off came back untaken, or the
            // neighbour cannot model it).
            if self.handoffs.is_queued(entity)
                || self.custody.adopted_from(entity).is_some()
                || self
                    .handoffs
                    .declined_by(entity, to, self.sim.tick(), &self.config)
            {
                continue;
            }
            if handoff::check(&self.sim, &self.config, &self.neighbours, entity, to).is_ok() {
                self.handoffs.queue(entity, to);
                self.events.emit(ClusterEvent::HandoffAsked { entity, to });
            }
        }
    }

    /// The events frame to `neighbour`. One taken for dead gets an empty frame (which tells
    /// it, should it be alive after all, that this cluster is): its entities are being
    /// adopted, so the ops and reports queued for it are kept to go, next tick on, to whoever
    /// owns their entities then.
    fn publish_events(&mut self, neighbour: ClusterId, tick: u64) -> Result<(), ClusterError> {
        let me = self.config.cluster_id;
        let gone = self.neighbours.is_gone(neighbour);
        let ops = self
            .routing
            .send(me, neighbour, tick, &self.retry, gone, &mut self.events);
        let contacts = self
            .reports
            .send(me, neighbour, tick, &self.retry, gone, &mut self.events);
        let frame = PhysicsEventsFrame {
            from: me,
            tick,
            stage: Stage::AfterStep,
            published_ns: monotonic_ns(),
            ops,
            acks: self.receipts.take_answers(neighbour),
            contacts,
            impulses: self.seam.take_for(neighbour),
            own_writes: Vec::new(),
            leaving: self.leaving,
            unmodelled: self.handoffs.take_unmodelled(neighbour),
            incarnation: self.incarnation,
        };
        self.publish_events_frame(neighbour, &frame)
    }

    /// Encodes `frame` straight into the transport's buffer for `neighbour` (on shm, the
    /// loaned sample).
    pub(super) fn publish_events_frame(
        &mut self,
        neighbour: ClusterId,
        frame: &PhysicsEventsFrame,
    ) -> Result<(), ClusterError> {
        let len = wire::encoded_len(frame);
        self.transport
            .publish_with(&channels::physics_events(neighbour), len, &mut |buffer| {
                wire::encode_into(frame, buffer).ok()
            })?;
        self.events.emit(ClusterEvent::EventsPublished {
            to: neighbour,
            bytes: len as u64,
        });
        Ok(())
    }
}
