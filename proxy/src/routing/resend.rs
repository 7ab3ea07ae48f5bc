//! Where an unanswered op goes next: to the cluster this one now knows to own its target, or
//! applied here if that is this cluster, or kept while its owner is taken for dead.

use seam_sim::wire::RoutedOp;

use super::apply::Arrival;
use super::{Owner, Routing};
use crate::clock::monotonic_ns;
use crate::delivery::{Courier, Resend, Retry, Route, Unanswered, Verdict};
use crate::events::{ClusterEvent, Name, OpDrop};

impl Courier<RoutedOp> for Owner<'_> {
    fn route(&mut self, name: Name, pending: &Unanswered<RoutedOp>, age: u64, tick: u64) -> Route {
        let target = pending.sent.op.target();
        match self.sim.info(target).map(|info| info.owner) {
            // Taken on to forward and the entity is back here (see `forwarded_back`).
            Some(owner) if owner == self.config.cluster_id && name.issuer != owner => {
                self.forwarded_back(name, pending, age, tick)
            }
            Some(owner) if owner == self.config.cluster_id => {
                // Adopted or handed here since: applied here, once, if young enough.
                match self.receipts.verdict(name) {
                    Verdict::New if age + 1 > self.config.max_op_age_ticks => {
                        let adopted_from = self.custody.adopted_from(target);
                        self.drop_closed(name, OpDrop::Stale, adopted_from);
                    }
                    Verdict::New => {
                        let arrival = Arrival {
                            published_ns: monotonic_ns(),
                            received_ns: monotonic_ns(),
                        };
                        self.apply_here(name, &pending.sent, &arrival, tick);
                    }
                    _ => self.events.emit(ClusterEvent::OpRepeated { name }),
                }
                Route::Done
            }
            Some(owner) if self.neighbours.reachable(owner) => Route::To(owner),
            // Its owner is taken for dead: its entities are being adopted; wait for the
            // adopter's frames to name it.
            Some(owner) if self.config.neighbours.contains(&owner) => Route::Wait,
            // Scenery, or an owner this cluster cannot send to; or not in this world and the
            // last receiver said it could not place it either.
            Some(_) => self.gone(name),
            None if pending.returned => self.gone(name),
            // Not in this world: the last receiver may still place it.
            None if self.neighbours.reachable(pending.to) => Route::To(pending.to),
            None => Route::Wait,
        }
    }

    fn note(&mut self, name: Name, what: Resend) {
        let event = match what {
            Resend::Resent(to) => ClusterEvent::OpResent { name, to },
            Resend::GivenUp => {
                tracing::warn!(
                    cluster = %self.config.label(self.config.cluster_id),
                    issuer = %self.config.label(name.issuer),
                    seq = name.seq,
                    "routed op given up: its owner never answered it (not running, or gone)"
                );
                ClusterEvent::OpDropped {
                    name,
                    reason: OpDrop::Expired,
                    adopted_from: None,
                }
            }
            Resend::NoRoom => ClusterEvent::OpDropped {
                name,
                reason: OpDrop::QueueFull,
                adopted_from: None,
            },
        };
        self.events.emit(event);
    }
}

impl Owner<'_> {
    /// An op another cluster issued, which this one took on to forward, whose entity is this
    /// cluster's again. Taking it on closed its name here, which says nothing of whether it
    /// was applied: the cluster it was forwarded to decides. Answered "not here", it was not
    /// applied there, and is applied here (if young enough); unanswered, that cluster is asked
    /// again (it answers a repeat done); if it cannot be reached, the op waits for its answer
    /// or its give-up, counted.
    fn forwarded_back(
        &mut self,
        name: Name,
        pending: &Unanswered<RoutedOp>,
        age: u64,
        tick: u64,
    ) -> Route {
        if !pending.returned {
            return if self.neighbours.reachable(pending.to) {
                Route::To(pending.to)
            } else {
                Route::Wait
            };
        }
        if age + 1 > self.config.max_op_age_ticks {
            let adopted_from = self.custody.adopted_from(pending.sent.op.target());
            self.drop_closed(name, OpDrop::Stale, adopted_from);
        } else {
            let arrival = Arrival {
                published_ns: monotonic_ns(),
                received_ns: monotonic_ns(),
            };
            self.apply_here(name, &pending.sent, &arrival, tick);
        }
        Route::Done
    }

    fn gone(&mut self, name: Name) -> Route {
        self.events.emit(ClusterEvent::OpDropped {
            name,
            reason: OpDrop::Gone,
            adopted_from: None,
        });
        Route::Done
    }
}

impl Routing {
    /// Sends again the unanswered ops that are due, each to the cluster this one now knows to
    /// own its target (or applies it, if that is this cluster); gives up on those too old to
    /// be applied anywhere, and on those whose entity neither this cluster nor the last
    /// receiver knows.
    pub(crate) fn resend_due(&mut self, tick: u64, retry: &Retry, at: &mut Owner<'_>) {
        let me = at.config.cluster_id;
        self.outbound.resend_due(me, tick, retry, at);
    }
}
