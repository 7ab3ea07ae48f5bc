//! [`Receipts`]: the receiver's side of delivery — each name closed once, every copy answered.

use seam_sim::wire::{ClusterId, IdMap, OpAck};

use super::window::{Closed, Verdict};
use crate::events::{ClusterEvent, Events, Name};

/// The names this cluster has closed, per issuer, and the answers it owes, per sender.
#[derive(Debug, Default)]
pub(crate) struct Receipts {
    closed: Closed,
    answers: IdMap<ClusterId, Vec<OpAck>>,
}

impl Receipts {
    /// What `name` is here.
    pub(crate) fn verdict(&self, name: Name) -> Verdict {
        self.closed.verdict(name)
    }

    /// Closes `name`: applied, dropped for good, or taken on to forward (an op), or surfaced
    /// (a report). An issuer's window forgotten to make room is an event.
    pub(crate) fn close(&mut self, name: Name, events: &mut Events) {
        let forgotten = self.closed.forgotten;
        self.closed.close(name);
        let count = self.closed.forgotten - forgotten;
        if count > 0 {
            events.emit(ClusterEvent::OpWindowsForgotten { count });
        }
    }

    /// Answers number `seq` of `issuer` (`None`: `to` itself) received from `to`, an op or a
    /// contact report, in the next events frame to `to`: the answer to the number before it
    /// grows when the two are consecutive numbers of one issuer, answered alike.
    pub(crate) fn answer(
        &mut self,
        to: ClusterId,
        seq: u64,
        issuer: Option<ClusterId>,
        done: bool,
    ) {
        let acks = self.answers.entry(to).or_default();
        if let Some(last) = acks.last_mut()
            && last.issuer == issuer
            && last.done == done
            && last.more < u16::MAX
            && last.seq.checked_add(u64::from(last.more) + 1) == Some(seq)
        {
            last.more += 1;
            return;
        }
        acks.push(OpAck {
            seq,
            more: 0,
            issuer,
            done,
        });
    }

    /// Takes the answers owed to `to`, for its events frame.
    pub(crate) fn take_answers(&mut self, to: ClusterId) -> Vec<OpAck> {
        self.answers
            .get_mut(&to)
            .map(std::mem::take)
            .unwrap_or_default()
    }
}
