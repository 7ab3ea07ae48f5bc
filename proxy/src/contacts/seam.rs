//! [`SeamImpulses`]: what contacts across the seam gave this cluster's bodies, sent to the
//! other body's owner, and both worlds' halves settled (see `settle`).

use seam_sim::wire::{ClusterId, IdMap, PhysicsEventsFrame, PhysicsOp, SeamImpulseReport};
use seam_sim::{BodyRole, ClusterSim};

use super::settle::Settlement;
use crate::config::ClusterConfig;
use crate::events::{ClusterEvent, Events};
use crate::neighbours::Neighbours;

/// The impulses at the seam on their way out, and this world's halves not settled yet.
#[derive(Default)]
pub(crate) struct SeamImpulses {
    /// By the proxy's owner, for this tick's frames.
    outgoing: IdMap<ClusterId, Vec<SeamImpulseReport>>,
    settlement: Settlement,
}

/// Whether `entity` is a body this cluster simulates.
fn simulated_here(sim: &ClusterSim, entity: seam_sim::wire::EntityId) -> bool {
    let me = sim.config().cluster_id;
    sim.info(entity)
        .is_some_and(|i| i.owner == me && i.role == BodyRole::Dynamic)
}

impl SeamImpulses {
    /// What contacts across the seam gave this cluster's bodies in the last step: noted for
    /// settling, and sent to each proxy's owner.
    pub(crate) fn report(&mut self, sim: &ClusterSim, config: &ClusterConfig, events: &mut Events) {
        // Without neighbours there is no proxy, so no seam.
        if !config.coupling || config.neighbours.is_empty() {
            return;
        }
        let tick = sim.tick();
        let impulses = sim.seam_impulses();
        for i in &impulses {
            let Some(owner) = sim.info(i.proxy).map(|info| info.owner) else {
                continue;
            };
            if config.neighbours.contains(&owner) {
                self.outgoing
                    .entry(owner)
                    .or_default()
                    .push(SeamImpulseReport {
                        own: i.own,
                        other: i.proxy,
                        impulse: i.impulse,
                        tick,
                    });
                events.emit(ClusterEvent::SeamImpulseSent { to: owner });
            }
        }
        self.settlement.record(tick, &impulses);
    }

    /// The reports for this tick's frame to `to`.
    pub(crate) fn take_for(&mut self, to: ClusterId) -> Vec<SeamImpulseReport> {
        self.outgoing
            .get_mut(&to)
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// Gives this cluster's bodies back half of what each world's contact across the seam gave
    /// them (see `settle`), as impulses, at the world's tick; halves wait `wait` ticks for
    /// their other half. Reports in `frames` naming a body this cluster does not simulate
    /// (handed on since), or with values that are not finite or beyond `max_magnitude`,
    /// change nothing and are counted. Returns the pushes for contacts the other world did
    /// not see, each for the other body's owner, to route.
    pub(crate) fn settle(
        &mut self,
        frames: &[(PhysicsEventsFrame, u64)],
        wait: u64,
        sim: &mut ClusterSim,
        config: &ClusterConfig,
        neighbours: &Neighbours,
        events: &mut Events,
    ) -> Vec<(ClusterId, PhysicsOp)> {
        let tick = sim.tick();
        let mut received = Vec::new();
        for (frame, _) in frames {
            for report in &frame.impulses {
                events.emit(ClusterEvent::SeamImpulseReceived);
                if !config.within_bound(report.impulse) {
                    events.emit(ClusterEvent::SeamImpulseDropped);
                } else if simulated_here(sim, report.other) {
                    received.push(*report);
                } else {
                    // About a body handed on since: nothing to give it here, but the other
                    // world saw the contact, so this world's half of it is no contact the
                    // other missed (passing it on would apply the contact twice).
                    self.settlement.seen(report);
                    events.emit(ClusterEvent::SeamImpulseDropped);
                }
            }
        }
        let settled = self.settlement.settle(received, tick, wait);
        if settled.disagreed > 0 {
            events.emit(ClusterEvent::SeamImpulsesDisagreed {
                count: settled.disagreed,
            });
        }
        if settled.unmatched > 0 {
            events.emit(ClusterEvent::SeamImpulsesUnmatched {
                count: settled.unmatched,
            });
        }
        let me = config.cluster_id;
        let mut unseen = Vec::new();
        for &(step, _, other, impulse) in &settled.unanswered {
            // A contact the other world did not see: the push it would have given the other
            // body goes to that body's owner. Only if the owner is alive and has published its
            // reports of that step: silence from a pod that stalled or died says nothing of
            // what it saw, and the push would be lost with it.
            let Some(owner) = sim.info(other).map(|i| i.owner) else {
                continue;
            };
            if owner == me || !config.neighbours.contains(&owner) {
                continue;
            }
            if !neighbours.has_reported(owner, step) {
                events.emit(ClusterEvent::SeamImpulseUnjudged);
                continue;
            }
            let op = PhysicsOp::Impulse {
                target: other,
                impulse: impulse.map(|c| -c),
            };
            unseen.push((owner, op));
            events.emit(ClusterEvent::SeamImpulseRouted { to: owner });
        }
        // Each pair's correction, to the bodies of it this cluster simulates: its own, and the
        // other world's if that was handed here since the step (nobody else gives it then).
        for (target, impulse) in settled.impulses {
            if simulated_here(sim, target) && sim.apply_settling(target, impulse).is_ok() {
                events.emit(ClusterEvent::SeamImpulseSettled { entity: target });
            }
        }
        unseen
    }
}
