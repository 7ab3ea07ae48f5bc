//! Contacts across the seam: reports to the proxy's owner (delivered like routed ops: kept
//! until answered, sent again to whoever owns the other entity, surfaced once), the impulses
//! each world gave its body, and settling them (see `crate::settle`).

use seam_sim::wire::{
    ClusterId, ContactReport, PhysicsEventsFrame, PhysicsOp, RoutedOp, SeamImpulseReport,
};
use seam_sim::{BodyRole, ContactEvent};

use crate::clock::monotonic_ns;
use crate::delivery::Verdict;
use crate::ledger::LedgerEvent;
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
            let seq = self.next_op_seq;
            self.next_op_seq += 1;
            self.outgoing_contacts
                .entry(destination)
                .or_default()
                .push(ContactReport {
                    seq,
                    age_ticks: 0,
                    a: contact.a,
                    b: contact.b,
                    started: contact.started,
                    tick,
                    impulse: contact.impulse,
                    normal: contact.normal,
                });
        }
    }

    /// Surfaces each contact once per side (see `crate::contact_merge`): this world's own of
    /// the last step, then the neighbours' reports. Each report's number is surfaced once; a
    /// report older than `max_op_age_ticks` is dropped. Every report is answered. Only local
    /// contacts with a neighbour's entity are remembered to merge: a report names one, and
    /// the rest (among this cluster's bodies, or with scenery) have no twin to meet.
    pub(super) fn surface_contacts(&mut self, events: &[(PhysicsEventsFrame, u64)]) {
        let tick = self.sim.tick();
        let max_age = self.config.max_op_age_ticks;
        self.contact_merge.expire(tick, max_age);
        let neighbours = &self.config.neighbours;
        let with_neighbour: Vec<bool> = self
            .sim
            .contacts()
            .iter()
            .map(|c| {
                [c.a, c.b].iter().any(|&id| {
                    self.sim
                        .info(id)
                        .is_some_and(|info| neighbours.contains(&info.owner))
                })
            })
            .collect();
        let merge = &mut self.contact_merge;
        let mut merged = 0;
        let mut index = 0;
        self.sim.retain_contacts(|c| {
            let crosses = with_neighbour[index];
            index += 1;
            let new = !crosses || merge.is_new(c, tick, 0, true);
            merged += u64::from(!new);
            new
        });
        let mut reported = Vec::new();
        for (frame, _) in events {
            for c in &frame.contacts {
                self.stats.contacts_received += 1;
                self.answer_number(frame.from, c.seq, None, true);
                let key = (frame.from, c.seq);
                match self.settled.verdict(key) {
                    Verdict::New => self.settle(key),
                    Verdict::Repeat => {
                        self.stats.contacts_repeated += 1;
                        continue;
                    }
                    Verdict::TooOld => {
                        self.stats.contacts_dropped_stale += 1;
                        self.note_contact(key, LedgerEvent::Stale);
                        continue;
                    }
                }
                if u64::from(c.age_ticks) + 1 > max_age {
                    self.stats.contacts_dropped_stale += 1;
                    self.note_contact(key, LedgerEvent::Stale);
                    continue;
                }
                // Surfaced below, or merged with this world's own copy.
                self.note_contact(key, LedgerEvent::Applied);
                let event = ContactEvent {
                    a: c.a,
                    b: c.b,
                    started: c.started,
                    impulse: c.impulse,
                    normal: c.normal,
                    reported_by: Some(frame.from),
                };
                let age = u64::from(c.age_ticks);
                if self
                    .contact_merge
                    .is_new(&event, tick.saturating_sub(age), age, false)
                {
                    reported.push(event);
                } else {
                    merged += 1;
                }
            }
        }
        self.stats.contacts_merged += merged;
        self.sim.add_contacts(reported);
    }

    /// Keeps the contact reports of this tick's frame to `to` until they are answered; returns
    /// those to send (the queue for `to` full, the rest are given up).
    pub(super) fn keep_unanswered_contacts(
        &mut self,
        to: ClusterId,
        reports: Vec<ContactReport>,
        tick: u64,
    ) -> Vec<ContactReport> {
        let me = self.config.cluster_id;
        let retry = self.config.op_retry_ticks.max(1);
        let kept = self
            .outstanding_contacts
            .keep_sent(me, to, reports, tick, retry);
        for &key in kept.new.iter().chain(&kept.refused) {
            self.stats.contacts_sent += 1;
            self.note_contact(key, LedgerEvent::Sent);
        }
        for &key in &kept.refused {
            self.stats.contacts_given_up += 1;
            self.note_contact(key, LedgerEvent::GivenUp);
        }
        kept.send
    }

    /// Sends again the unanswered contact reports that are due, each to the cluster this one
    /// now knows to own the pair's other entity (or, if this world no longer models it, to
    /// the last receiver); gives up on those past answering, and on those with nobody left to
    /// tell (out of this world's view with its last receiver gone), and forgets those whose
    /// pair is this cluster's own now.
    pub(super) fn resend_due_contacts(&mut self, tick: u64) {
        let me = self.config.cluster_id;
        for (key, mut pending) in self.outstanding_contacts.take_due(tick) {
            let age = pending.age(tick);
            if self.past_answering(age) {
                self.stats.contacts_given_up += 1;
                self.note_contact(key, LedgerEvent::GivenUp);
                continue;
            }
            let report = pending.sent;
            let owners: Vec<ClusterId> = [report.a, report.b]
                .iter()
                .filter_map(|&id| self.sim.info(id).map(|info| info.owner))
                .filter(|&owner| owner != me && self.config.neighbours.contains(&owner))
                .collect();
            let alive = |c: &ClusterId| {
                !self
                    .neighbour_status(*c)
                    .is_some_and(NeighbourStatus::is_gone)
            };
            let unknown = [report.a, report.b]
                .iter()
                .any(|&id| self.sim.info(id).is_none());
            let to = if owners.contains(&pending.to) && alive(&pending.to) {
                Some(pending.to)
            } else if let Some(&owner) = owners.iter().find(|c| alive(c)) {
                Some(owner)
            } else if !owners.is_empty() {
                // Its owner is taken for dead: wait for the adopter's frames to name it.
                None
            } else if unknown && alive(&pending.to) {
                // Out of this world's view since: the last receiver still knows it.
                Some(pending.to)
            } else if unknown {
                self.stats.contacts_given_up += 1;
                self.note_contact(key, LedgerEvent::GivenUp);
                continue;
            } else {
                // Both bodies are this cluster's now (adopted, or handed here): its own game
                // code saw the contact, and there is no other owner to tell.
                self.stats.contacts_own_now += 1;
                self.note_contact(key, LedgerEvent::GivenUp);
                continue;
            };
            pending.due_tick = tick + self.config.op_retry_ticks.max(1);
            if let Some(to) = to {
                pending.to = to;
                self.outgoing_contacts
                    .entry(to)
                    .or_default()
                    .push(ContactReport {
                        age_ticks: u32::try_from(age).unwrap_or(u32::MAX),
                        ..report
                    });
                self.stats.contacts_resent += 1;
            }
            if !self.outstanding_contacts.keep(key, pending) {
                self.stats.contacts_given_up += 1;
                self.note_contact(key, LedgerEvent::GivenUp);
            }
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
