//! The routed ops received for this cluster's entities: applied once, just before the step, or
//! forwarded once after a hand-off, or answered "not here"; every one answered.

use seam_sim::wire::{ClusterId, PhysicsEventsFrame, RoutedOp};

use super::{Owner, Routing};
use crate::clock::monotonic_ns;
use crate::delivery::Verdict;
use crate::events::{ClusterEvent, Name, OpDrop, OpTiming};

/// When the frame that brought an op was published and received, for its stage times.
pub(super) struct Arrival {
    pub(super) published_ns: u64,
    pub(super) received_ns: u64,
}

impl Owner<'_> {
    /// Answers an op received from `to` in its next events frame.
    fn answer(&mut self, to: ClusterId, routed: &RoutedOp, done: bool) {
        self.receipts.answer(to, routed.seq, routed.issuer, done);
    }

    /// Applies an op on an entity this cluster owns, and notes its stage times.
    pub(super) fn apply_here(
        &mut self,
        name: Name,
        routed: &RoutedOp,
        arrival: &Arrival,
        tick: u64,
    ) {
        self.close(name);
        // The steps its body took since the issuer's tick without it (a tick, in lock-step):
        // their motion is added back, so it acts as if applied on the tick it was issued.
        let missed = tick
            .saturating_sub(routed.issued_tick)
            .min(self.config.max_op_age_ticks);
        match self.sim.apply_op_late(&routed.op, missed) {
            Ok(()) => {
                let target = routed.op.target();
                let timing = OpTiming {
                    from: name.issuer,
                    target,
                    issued_ns: routed.issued_ns,
                    published_ns: arrival.published_ns,
                    received_ns: arrival.received_ns,
                    applied_ns: monotonic_ns(),
                    issued_tick: routed.issued_tick,
                    applied_tick: tick,
                };
                self.events.emit(ClusterEvent::OpApplied {
                    name,
                    timing,
                    adopted_from: self.custody.adopted_from(target),
                });
            }
            Err(_) => self.events.emit(ClusterEvent::OpDropped {
                name,
                reason: OpDrop::Invalid,
                adopted_from: None,
            }),
        }
    }
}

impl Routing {
    /// Applies the ops received for this cluster's entities, just before the step, each name
    /// once; an op whose target was handed over since the issuer routed it is taken on and
    /// sent, once, to the owner this cluster knows; one it cannot place is answered "not
    /// here"; absurd, stale, invalid and repeated ops are counted and dropped. Every op is
    /// answered.
    pub(crate) fn apply_received(
        &mut self,
        frames: &[(PhysicsEventsFrame, u64)],
        tick: u64,
        at: &mut Owner<'_>,
    ) {
        for (frame, received_ns) in frames {
            let arrival = Arrival {
                published_ns: frame.published_ns,
                received_ns: *received_ns,
            };
            for routed in &frame.ops {
                let done = self.receive(frame.from, routed, &arrival, tick, at);
                at.answer(frame.from, routed, done);
            }
        }
    }

    /// What becomes of one op received from `from`; returns whether it is done here (else
    /// "not here").
    fn receive(
        &mut self,
        from: ClusterId,
        routed: &RoutedOp,
        arrival: &Arrival,
        tick: u64,
        at: &mut Owner<'_>,
    ) -> bool {
        let name = Name::new(routed.issuer.unwrap_or(from), routed.seq);
        match at.receipts.verdict(name) {
            Verdict::Repeat => {
                at.events.emit(ClusterEvent::OpRepeated { name });
                return true;
            }
            Verdict::TooOld => {
                at.events.emit(ClusterEvent::OpDropped {
                    name,
                    reason: OpDrop::Window,
                    adopted_from: None,
                });
                return true;
            }
            Verdict::New => {}
        }
        if let Some(v) = routed.op.vector()
            && v.iter().all(|c| c.is_finite())
            && !at.config.within_bound(v)
        {
            at.drop_closed(name, OpDrop::Absurd, None);
            return true;
        }
        // Its age when applied: the ticks it spent in its senders' hands and the one it waits
        // here.
        if u64::from(routed.age_ticks) + 1 > at.config.max_op_age_ticks {
            at.drop_closed(name, OpDrop::Stale, None);
            return true;
        }
        match at.sim.info(routed.op.target()).map(|info| info.owner) {
            Some(owner) if owner == at.config.cluster_id => {
                at.apply_here(name, routed, arrival, tick);
                true
            }
            // Handed over since the issuer routed it: taken on and sent, once, to the owner
            // this cluster knows, which answers this cluster.
            Some(owner) if !routed.forwarded() && at.neighbours.reachable(owner) => {
                at.close(name);
                self.outbound.queue(
                    owner,
                    RoutedOp {
                        issuer: Some(from),
                        age_ticks: routed.age_ticks.saturating_add(1),
                        ..*routed
                    },
                );
                at.events
                    .emit(ClusterEvent::OpForwarded { name, to: owner });
                true
            }
            _ => {
                at.events.emit(ClusterEvent::OpNotHere { name });
                false
            }
        }
    }
}
