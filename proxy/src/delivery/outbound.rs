//! [`Outbound`]: the sender's side of delivery — items queued for this tick's frames, kept
//! until answered, sent again while due.

use seam_sim::wire::{ClusterId, IdMap, PhysicsEventsFrame};

use super::Retry;
use super::outstanding::{Kept, Numbered, Outstanding, Unanswered};
use crate::events::Name;

/// Where an unanswered item due again goes (a [`Courier`]'s answer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Route {
    /// Sent again, to this cluster.
    To(ClusterId),
    /// Kept, unsent: nobody to send it to yet (its owner is taken for dead, and its adopter
    /// not known).
    Wait,
    /// Done with: the courier closed it (applied it here, or dropped or gave it up).
    Done,
}

/// What became of an unanswered item when it was due (told to the [`Courier`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Resend {
    /// Sent again to this cluster.
    Resent(ClusterId),
    /// Given up: past answering.
    GivenUp,
    /// No room left to keep it for its destination: dropped.
    NoRoom,
}

/// What differs between the kinds of item delivered: where one goes next, and what is noted
/// of it.
pub(crate) trait Courier<T> {
    /// Where `pending`, named `name`, due again at `tick` at `age`, goes.
    fn route(&mut self, name: Name, pending: &Unanswered<T>, age: u64, tick: u64) -> Route;
    /// Notes what became of it.
    fn note(&mut self, name: Name, what: Resend);
}

/// Items (routed ops or contact reports) queued for this tick's frames, by destination, and
/// those sent and not answered yet.
#[derive(Debug)]
pub(crate) struct Outbound<T> {
    queued: IdMap<ClusterId, Vec<T>>,
    unanswered: Outstanding<T>,
}

impl<T> Default for Outbound<T> {
    fn default() -> Self {
        Self {
            queued: IdMap::default(),
            unanswered: Outstanding::default(),
        }
    }
}

impl<T: Numbered> Outbound<T> {
    /// Queues `item` for this tick's frame to `to`.
    pub(crate) fn queue(&mut self, to: ClusterId, item: T) {
        self.queued.entry(to).or_default().push(item);
    }

    /// Everything queued for this tick's frames.
    pub(crate) fn queued(&self) -> impl Iterator<Item = &T> {
        self.queued.values().flatten()
    }

    /// How many items are unanswered.
    pub(crate) fn unanswered(&self) -> usize {
        self.unanswered.len()
    }

    /// The names of the items unanswered.
    pub(crate) fn names(&self) -> impl Iterator<Item = Name> + '_ {
        self.unanswered.names()
    }

    /// Takes in the answers in `frames` to what cluster `me` sent: each answered done is
    /// forgotten and passed to `answered`; those answered "not here" are due again at `tick`.
    pub(crate) fn take_answers(
        &mut self,
        frames: &[(PhysicsEventsFrame, u64)],
        me: ClusterId,
        tick: u64,
        mut answered: impl FnMut(Name),
    ) {
        for (frame, _) in frames {
            for ack in &frame.acks {
                let issuer = ack.issuer.unwrap_or(me);
                for seq in ack.seqs() {
                    let name = Name::new(issuer, seq);
                    if !ack.done {
                        self.unanswered.returned(name, tick);
                    } else if self.unanswered.take(name).is_some() {
                        answered(name);
                    }
                }
            }
        }
    }

    /// Takes what is queued for `to` as cluster `me` sends it at `tick`: those sent for the
    /// first time are kept until answered (if the queue for `to` has room); resends are kept
    /// already.
    pub(crate) fn send(
        &mut self,
        me: ClusterId,
        to: ClusterId,
        tick: u64,
        retry: &Retry,
    ) -> Kept<T> {
        let items = self
            .queued
            .get_mut(&to)
            .map(std::mem::take)
            .unwrap_or_default();
        self.unanswered.keep_sent(me, to, items, tick, retry.every)
    }

    /// Keeps `items`, meant for a neighbour taken for dead, unsent: each is due again at the
    /// next tick, to go wherever its entity is owned then.
    pub(crate) fn hold(&mut self, me: ClusterId, items: &mut Vec<T>, tick: u64) {
        for item in items.drain(..) {
            self.unanswered.due_at(item.name(me), tick + 1);
        }
    }

    /// Sends again, as cluster `me` at `tick`, every unanswered item that is due, where
    /// `courier` routes it; gives up those past answering.
    pub(crate) fn resend_due(
        &mut self,
        me: ClusterId,
        tick: u64,
        retry: &Retry,
        courier: &mut impl Courier<T>,
    ) {
        for (name, mut pending) in self.unanswered.take_due(tick) {
            let age = pending.age(tick);
            if age >= retry.give_up_at {
                courier.note(name, Resend::GivenUp);
                continue;
            }
            let to = match courier.route(name, &pending, age, tick) {
                Route::Done => continue,
                Route::Wait => None,
                Route::To(to) => Some(to),
            };
            pending.returned = false;
            pending.due_tick = tick + retry.every;
            if let Some(to) = to {
                pending.to = to;
                self.queue(to, pending.sent.resent(me, name, age));
                courier.note(name, Resend::Resent(to));
            }
            if !self.unanswered.keep(name, pending) {
                courier.note(name, Resend::NoRoom);
            }
        }
    }
}
