//! Routed writes: game code's writes on remote-owned entities queued for their owners
//! ([`Outbox`]), the ops received for this cluster's entities applied once (or forwarded once
//! after a hand-off) and answered, and this cluster's unanswered ops sent again to whoever owns
//! their target now (see `crate::delivery`).
//!
//! # Layout
//!
//! - here: [`Routing`], this cluster's ops on their way, and [`Owner`], what applying one
//!   reads and changes.
//! - `outbox` — [`Outbox`]: game code's writes, numbered and queued by owner.
//! - `apply` — the ops received: applied, forwarded, answered.
//! - `resend` — where an unanswered op goes next.

mod apply;
mod outbox;
mod resend;

use seam_sim::ClusterSim;
use seam_sim::wire::{ClusterId, PhysicsOp, RoutedOp};

use crate::clock::monotonic_ns;
use crate::config::ClusterConfig;
use crate::delivery::{Numbers, Outbound, Receipts, Retry};
use crate::events::{ClusterEvent, Events, Name, OpDrop};
use crate::neighbours::{Custody, Neighbours};

pub(crate) use outbox::Outbox;

/// What applying a routed op reads and changes: the world, and the parts that say who owns
/// what and what was closed.
pub(crate) struct Owner<'a> {
    pub(crate) sim: &'a mut ClusterSim,
    pub(crate) config: &'a ClusterConfig,
    pub(crate) neighbours: &'a Neighbours,
    pub(crate) custody: &'a Custody,
    pub(crate) receipts: &'a mut Receipts,
    pub(crate) events: &'a mut Events,
}

impl Owner<'_> {
    /// Closes `name` here.
    fn close(&mut self, name: Name) {
        self.receipts.close(name, self.events);
    }

    /// Closes `name`, dropped for `reason`.
    fn drop_closed(&mut self, name: Name, reason: OpDrop, adopted_from: Option<ClusterId>) {
        self.close(name);
        self.events.emit(ClusterEvent::OpDropped {
            name,
            reason,
            adopted_from,
        });
    }
}

/// `op` issued here at `tick`, with the next number.
fn issued(op: PhysicsOp, numbers: &mut Numbers, tick: u64) -> RoutedOp {
    RoutedOp {
        op,
        seq: numbers.take(),
        issuer: None,
        issued_ns: monotonic_ns(),
        issued_tick: tick,
        age_ticks: 0,
    }
}

/// This cluster's routed ops on their way: queued for this tick's frames, and unanswered.
#[derive(Debug, Default)]
pub(crate) struct Routing {
    outbound: Outbound<RoutedOp>,
    /// Impulses game code gave this cluster's own bodies this tick, for the exchange.
    own_writes: Vec<PhysicsOp>,
}

impl Routing {
    /// The writes game code makes this tick, numbered from `numbers`, queued for their owners
    /// among `neighbours`; with `exchange`, the impulses it gives this cluster's own bodies
    /// are noted too, for [`Routing::own_writes`].
    pub(crate) fn outbox<'a>(
        &'a mut self,
        numbers: &'a mut Numbers,
        neighbours: &'a [ClusterId],
        tick: u64,
        exchange: bool,
    ) -> Outbox<'a> {
        self.own_writes.clear();
        let own = exchange.then_some(&mut self.own_writes);
        Outbox::new(&mut self.outbound, numbers, neighbours, tick, own)
    }

    /// The impulses game code gave this cluster's own bodies this tick (noted when the outbox
    /// was opened with `exchange`).
    pub(crate) fn own_writes(&self) -> &[PhysicsOp] {
        &self.own_writes
    }

    /// Everything queued for this tick's frames.
    pub(crate) fn queued(&self) -> impl Iterator<Item = &RoutedOp> {
        self.outbound.queued()
    }

    /// Issues `op` from this cluster at `tick`, for `to`.
    pub(crate) fn issue(&mut self, to: ClusterId, op: PhysicsOp, numbers: &mut Numbers, tick: u64) {
        self.outbound.queue(to, issued(op, numbers, tick));
    }

    /// Ops sent and not answered yet.
    pub(crate) fn unanswered(&self) -> usize {
        self.outbound.unanswered()
    }

    /// Their names.
    pub(crate) fn names(&self) -> impl Iterator<Item = Name> + '_ {
        self.outbound.names()
    }

    /// Takes in the answers to the ops this cluster (`me`) sent.
    pub(crate) fn take_answers(
        &mut self,
        frames: &[(seam_sim::wire::PhysicsEventsFrame, u64)],
        me: ClusterId,
        tick: u64,
        events: &mut Events,
    ) {
        self.outbound.take_answers(frames, me, tick, |name| {
            events.emit(ClusterEvent::OpAnswered { name });
        });
    }

    /// The ops for this tick's frame to `to`, kept until answered (those the queue for `to`
    /// has no room for are dropped). `gone`: `to` is taken for dead, so they are kept unsent,
    /// to go next tick to whoever owns their entities then.
    pub(crate) fn send(
        &mut self,
        me: ClusterId,
        to: ClusterId,
        tick: u64,
        retry: &Retry,
        gone: bool,
        events: &mut Events,
    ) -> Vec<RoutedOp> {
        let kept = self.outbound.send(me, to, tick, retry);
        for &name in kept.new.iter().chain(&kept.refused) {
            events.emit(ClusterEvent::OpSent {
                name,
                issued_here: name.issuer == me,
            });
        }
        for &name in &kept.refused {
            events.emit(ClusterEvent::OpDropped {
                name,
                reason: OpDrop::QueueFull,
                adopted_from: None,
            });
        }
        let mut ops = kept.send;
        if gone {
            self.outbound.hold(me, &mut ops, tick);
        }
        ops
    }
}
