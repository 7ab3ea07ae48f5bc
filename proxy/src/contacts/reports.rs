//! [`Reports`]: contacts between this cluster's bodies and proxies, sent to the proxy's owner
//! (kept until answered, sent again to whoever owns the other entity), and the neighbours'
//! reports surfaced once (see `merge`).

use seam_sim::wire::{ClusterId, ContactReport, PhysicsEventsFrame};
use seam_sim::{ClusterSim, ContactEvent};

use super::merge::ContactMerge;
use crate::config::ClusterConfig;
use crate::delivery::{
    Courier, Numbers, Outbound, Receipts, Resend, Retry, Route, Unanswered, Verdict,
};
use crate::events::{ClusterEvent, ContactGiveUp, Events, Name};
use crate::neighbours::{Custody, Neighbours};

/// This cluster's contact reports on their way, and the contacts surfaced lately.
#[derive(Default)]
pub(crate) struct Reports {
    outbound: Outbound<ContactReport>,
    /// Contacts surfaced lately, so each surfaces once.
    merge: ContactMerge,
}

impl Reports {
    /// Contact reports sent and not answered yet.
    pub(crate) fn unanswered(&self) -> usize {
        self.outbound.unanswered()
    }

    /// Their names.
    pub(crate) fn names(&self) -> impl Iterator<Item = Name> + '_ {
        self.outbound.names()
    }

    /// Contacts of the last step between a body owned here and a proxy go to the proxy's
    /// owner, numbered from `numbers`.
    pub(crate) fn report(
        &mut self,
        sim: &ClusterSim,
        config: &ClusterConfig,
        numbers: &mut Numbers,
    ) {
        let me = config.cluster_id;
        let tick = sim.tick();
        let owner = |id| sim.info(id).map(|i| i.owner);
        for contact in sim.contacts().iter().filter(|c| c.reported_by.is_none()) {
            let (Some(owner_a), Some(owner_b)) = (owner(contact.a), owner(contact.b)) else {
                continue;
            };
            let destination = match (owner_a == me, owner_b == me) {
                (true, false) => owner_b,
                (false, true) => owner_a,
                _ => continue,
            };
            if !config.neighbours.contains(&destination) {
                // Scenery: nobody's to report to.
                continue;
            }
            self.outbound.queue(
                destination,
                ContactReport {
                    seq: numbers.take(),
                    age_ticks: 0,
                    a: contact.a,
                    b: contact.b,
                    started: contact.started,
                    tick,
                    impulse: contact.impulse,
                    normal: contact.normal,
                },
            );
        }
    }

    /// Surfaces each contact once per side (see `merge`): this world's own of the last step,
    /// then the neighbours' reports in `frames`. Each report's number is surfaced once; a
    /// report older than `max_op_age_ticks` is dropped. Every report is answered. Only local
    /// contacts with a neighbour's entity are remembered to merge: a report names one, and
    /// the rest (among this cluster's bodies, or with scenery) have no twin to meet. A report
    /// on a body held here for a neighbour taken for dead (`custody`) says so when taken.
    pub(crate) fn surface(
        &mut self,
        frames: &[(PhysicsEventsFrame, u64)],
        sim: &mut ClusterSim,
        config: &ClusterConfig,
        custody: &Custody,
        receipts: &mut Receipts,
        events: &mut Events,
    ) {
        let tick = sim.tick();
        let max_age = config.max_op_age_ticks;
        self.merge.expire(tick, max_age);
        let with_neighbour: Vec<bool> = sim
            .contacts()
            .iter()
            .map(|c| {
                [c.a, c.b].iter().any(|&id| {
                    sim.info(id)
                        .is_some_and(|info| config.neighbours.contains(&info.owner))
                })
            })
            .collect();
        let merge = &mut self.merge;
        let mut merged = 0;
        let mut index = 0;
        sim.retain_contacts(|c| {
            let crosses = with_neighbour[index];
            index += 1;
            let new = !crosses || merge.is_new(c, tick, 0, true);
            merged += u64::from(!new);
            new
        });
        let mut reported = Vec::new();
        for (frame, _) in frames {
            for c in &frame.contacts {
                let adopted_from = custody.adopted_from(c.a).or(custody.adopted_from(c.b));
                if take_report(frame.from, c, max_age, adopted_from, receipts, events) {
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
                        .merge
                        .is_new(&event, tick.saturating_sub(age), age, false)
                    {
                        reported.push(event);
                    } else {
                        merged += 1;
                    }
                }
            }
        }
        if merged > 0 {
            events.emit(ClusterEvent::ContactsMerged { count: merged });
        }
        sim.add_contacts(reported);
    }

    /// Takes in the answers to the reports this cluster (`me`) sent.
    pub(crate) fn take_answers(
        &mut self,
        frames: &[(PhysicsEventsFrame, u64)],
        me: ClusterId,
        tick: u64,
        events: &mut Events,
    ) {
        self.outbound.take_answers(frames, me, tick, |name| {
            events.emit(ClusterEvent::ContactAnswered { name });
        });
    }

    /// The reports for this tick's frame to `to`, kept until answered (those the queue for
    /// `to` has no room for are given up). `gone`: `to` is taken for dead, so they are kept
    /// unsent, to go next tick to whoever owns the other entity then.
    pub(crate) fn send(
        &mut self,
        me: ClusterId,
        to: ClusterId,
        tick: u64,
        retry: &Retry,
        gone: bool,
        events: &mut Events,
    ) -> Vec<ContactReport> {
        let kept = self.outbound.send(me, to, tick, retry);
        for &name in kept.new.iter().chain(&kept.refused) {
            events.emit(ClusterEvent::ContactReported { name });
        }
        for &name in &kept.refused {
            events.emit(ClusterEvent::ContactGivenUp {
                name,
                reason: ContactGiveUp::QueueFull,
            });
        }
        let mut reports = kept.send;
        if gone {
            self.outbound.hold(me, &mut reports, tick);
        }
        reports
    }

    /// Sends again the unanswered reports that are due, each to the cluster this one now
    /// knows to own the pair's other entity (or, if this world no longer models it, to the
    /// last receiver); gives up on those past answering, and on those with nobody left to
    /// tell, and forgets those whose pair is this cluster's own now.
    pub(crate) fn resend_due(
        &mut self,
        tick: u64,
        retry: &Retry,
        sim: &ClusterSim,
        config: &ClusterConfig,
        neighbours: &Neighbours,
        events: &mut Events,
    ) {
        let mut courier = ReportCourier {
            sim,
            config,
            neighbours,
            events,
        };
        self.outbound
            .resend_due(config.cluster_id, tick, retry, &mut courier);
    }
}

/// Answers report `c` from `from` and closes its name; returns whether it is to surface
/// (new, and young enough). `adopted_from`: the cluster a body of the report is held for here.
fn take_report(
    from: ClusterId,
    c: &ContactReport,
    max_age: u64,
    adopted_from: Option<ClusterId>,
    receipts: &mut Receipts,
    events: &mut Events,
) -> bool {
    let name = Name::new(from, c.seq);
    events.emit(ClusterEvent::ContactReceived { name });
    receipts.answer(from, c.seq, None, true);
    match receipts.verdict(name) {
        Verdict::New => receipts.close(name, events),
        Verdict::Repeat => {
            events.emit(ClusterEvent::ContactRepeated { name });
            return false;
        }
        Verdict::TooOld => {
            events.emit(ClusterEvent::ContactStale { name });
            return false;
        }
    }
    if u64::from(c.age_ticks) + 1 > max_age {
        events.emit(ClusterEvent::ContactStale { name });
        return false;
    }
    // Surfaced by the caller, or merged with this world's own copy.
    events.emit(ClusterEvent::ContactDelivered { name, adopted_from });
    true
}

/// Where an unanswered report goes next.
struct ReportCourier<'a> {
    sim: &'a ClusterSim,
    config: &'a ClusterConfig,
    neighbours: &'a Neighbours,
    events: &'a mut Events,
}

impl ReportCourier<'_> {
    fn give_up(&mut self, name: Name, reason: ContactGiveUp) -> Route {
        self.events
            .emit(ClusterEvent::ContactGivenUp { name, reason });
        Route::Done
    }
}

impl Courier<ContactReport> for ReportCourier<'_> {
    fn route(
        &mut self,
        name: Name,
        pending: &Unanswered<ContactReport>,
        _age: u64,
        _tick: u64,
    ) -> Route {
        let me = self.config.cluster_id;
        let report = pending.sent;
        let owners: Vec<ClusterId> = [report.a, report.b]
            .iter()
            .filter_map(|&id| self.sim.info(id).map(|info| info.owner))
            .filter(|&owner| owner != me && self.config.neighbours.contains(&owner))
            .collect();
        let alive = |c: &ClusterId| !self.neighbours.is_gone(*c);
        let unknown = [report.a, report.b]
            .iter()
            .any(|&id| self.sim.info(id).is_none());
        if owners.contains(&pending.to) && alive(&pending.to) {
            Route::To(pending.to)
        } else if let Some(&owner) = owners.iter().find(|c| alive(c)) {
            Route::To(owner)
        } else if !owners.is_empty() {
            // Its owner is taken for dead: wait for the adopter's frames to name it.
            Route::Wait
        } else if unknown && alive(&pending.to) {
            // Out of this world's view since: the last receiver still knows it.
            Route::To(pending.to)
        } else if unknown {
            self.give_up(name, ContactGiveUp::NobodyToTell)
        } else {
            // Both bodies are this cluster's now (adopted, or handed here): its own game code
            // saw the contact, and there is no other owner to tell.
            self.give_up(name, ContactGiveUp::OwnNow)
        }
    }

    fn note(&mut self, name: Name, what: Resend) {
        let event = match what {
            Resend::Resent(to) => ClusterEvent::ContactResent { name, to },
            Resend::GivenUp => ClusterEvent::ContactGivenUp {
                name,
                reason: ContactGiveUp::PastAnswering,
            },
            Resend::NoRoom => ClusterEvent::ContactGivenUp {
                name,
                reason: ContactGiveUp::QueueFull,
            },
        };
        self.events.emit(event);
    }
}
