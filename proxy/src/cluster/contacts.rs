//! Contacts across the seam: reports to the proxy's owner, the impulses each world gave its
//! body, and settling them (see `crate::settle`).

use seam_sim::BodyRole;
use seam_sim::wire::{ContactReport, PhysicsEventsFrame, PhysicsOp, RoutedOp, SeamImpulseReport};

use crate::clock::monotonic_ns;
use crate::settle::HALF_WAITS_TICKS;

use super::{Cluster, NeighbourStatus, within};

impl Cluster {
    /// Contacts of the last step between a body owned here and a proxy go to the proxy's owner.
    pub(super) fn report_contacts(&mut self) {
        let me = self.config.cluster_id;
        let tick = self.sim.tick();
        for contact in self
            .sim
            .contacts()
            .iter()
            .filter(|c| c.reported_by.is_none())
        {
            let owner = |id| self.sim.info(id).map(|i| i.owner);
            let (Some(owner_a), Some(owner_b)) = (owner(contact.a), owner(contact.b)) else {
                continue;
            };
            let destination = match (owner_a == me, owner_b == me) {
                (true, false) => owner_b,
                (false, true) => owner_a,
                _ => continue,
            };
            if !self.config.neighbours.contains(&destination) {
                // Scenery: nobody's to report to.
                continue;
            }
            self.outgoing_contacts
                .entry(destination)
                .or_default()
                .push(ContactReport {
                    a: contact.a,
                    b: contact.b,
                    started: contact.started,
                    tick,
                    impulse: contact.impulse,
                    normal: contact.normal,
                });
            self.stats.contacts_sent += 1;
        }
    }

    /// What contacts across the seam gave this cluster's bodies in the last step: noted for
    /// settling, and sent to each proxy's owner.
    pub(super) fn report_seam_impulses(&mut self) {
        if !self.config.coupling {
            return;
        }
        let tick = self.sim.tick();
        let impulses = self.sim.seam_impulses();
        for i in &impulses {
            let Some(owner) = self.sim.info(i.proxy).map(|info| info.owner) else {
                continue;
            };
            if self.config.neighbours.contains(&owner) {
                self.outgoing_impulses
                    .entry(owner)
                    .or_default()
                    .push(SeamImpulseReport {
                        own: i.own,
                        other: i.proxy,
                        impulse: i.impulse,
                        tick,
                    });
                self.stats.seam_impulses_sent += 1;
            }
        }
        self.settlement.record(tick, &impulses);
    }

    /// Gives this cluster's bodies back half of what each world's contact across the seam gave
    /// them (see `crate::settle`), as impulses. Reports naming a body this cluster does not
    /// simulate (handed on since), or with values that are not finite or beyond
    /// `max_magnitude`, change nothing and are counted.
    pub(super) fn settle_seam_impulses(&mut self, events: &[(PhysicsEventsFrame, u64)], tick: u64) {
        let me = self.config.cluster_id;
        let limit = self.config.max_magnitude;
        let mut received = Vec::new();
        for (frame, _) in events {
            for report in &frame.impulses {
                self.stats.seam_impulses_received += 1;
                let simulated_here = self
                    .sim
                    .info(report.other)
                    .is_some_and(|i| i.owner == me && i.role == BodyRole::Dynamic);
                if simulated_here && within(report.impulse, limit) {
                    received.push(*report);
                } else {
                    self.stats.seam_impulses_dropped += 1;
                }
            }
        }
        let wait = if self.free_running {
            HALF_WAITS_TICKS
        } else {
            0
        };
        let settled = self.settlement.settle(received, tick, wait);
        self.stats.seam_impulses_disagreed += settled.disagreed;
        self.stats.seam_impulses_unmatched += settled.unmatched;
        for &(step, _, other, impulse) in &settled.unanswered {
            // A contact the other world did not see: the push it would have given the other
            // body goes to that body's owner. Only if the owner is alive and has published its
            // reports of that step: silence from a pod that stalled or died says nothing of
            // what it saw, and the push would be lost with it.
            let Some(owner) = self.sim.info(other).map(|i| i.owner) else {
                continue;
            };
            if owner == me || !self.config.neighbours.contains(&owner) {
                continue;
            }
            let reported_step = self.liveness.get(&owner).is_some_and(|peer| {
                peer.status == NeighbourStatus::Alive
                    && peer.newest_events.is_some_and(|newest| newest >= step)
            });
            if !reported_step {
                self.stats.seam_impulses_unjudged += 1;
                continue;
            }
            let seq = self.next_op_seq;
            self.next_op_seq += 1;
            self.outgoing_ops.entry(owner).or_default().push(RoutedOp {
                op: PhysicsOp::Impulse {
                    target: other,
                    impulse: impulse.map(|c| -c),
                },
                seq,
                issuer: None,
                issued_ns: monotonic_ns(),
                issued_tick: tick,
                age_ticks: 0,
            });
            self.stats.seam_impulses_routed += 1;
        }
        for (target, impulse) in settled.impulses {
            let simulated_here = self
                .sim
                .info(target)
                .is_some_and(|i| i.owner == me && i.role == BodyRole::Dynamic);
            if simulated_here
                && self
                    .sim
                    .apply_op(&PhysicsOp::Impulse { target, impulse })
                    .is_ok()
            {
                self.stats.seam_impulses_settled += 1;
            }
        }
    }
}
