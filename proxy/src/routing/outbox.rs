//! [`Outbox`]: game code's writes on remote-owned entities, numbered and queued by owner until
//! the tick publishes.

use seam_sim::wire::{ClusterId, PhysicsOp, RoutedOp};
use seam_sim::{SimError, WriteRouter};

use crate::delivery::{Numbers, Outbound};

/// Where game code's writes on remote-owned entities go during a tick.
pub(crate) struct Outbox<'a> {
    outbound: &'a mut Outbound<RoutedOp>,
    numbers: &'a mut Numbers,
    neighbours: &'a [ClusterId],
    tick: u64,
    /// Where impulses game code gives this cluster's own bodies are noted (for the exchange),
    /// if anywhere.
    own_writes: Option<&'a mut Vec<PhysicsOp>>,
}

impl<'a> Outbox<'a> {
    pub(super) fn new(
        outbound: &'a mut Outbound<RoutedOp>,
        numbers: &'a mut Numbers,
        neighbours: &'a [ClusterId],
        tick: u64,
        own_writes: Option<&'a mut Vec<PhysicsOp>>,
    ) -> Self {
        Self {
            outbound,
            numbers,
            neighbours,
            tick,
            own_writes,
        }
    }
}

impl WriteRouter for Outbox<'_> {
    fn route(&mut self, owner: ClusterId, op: PhysicsOp) -> Result<(), SimError> {
        if !self.neighbours.contains(&owner) {
            return Err(SimError::NotOwned {
                entity: op.target(),
                owner,
            });
        }
        self.outbound
            .queue(owner, super::issued(op, self.numbers, self.tick));
        Ok(())
    }

    fn applied(&mut self, op: &PhysicsOp) {
        // Impulses add up, so a neighbour can show them on its proxy whatever else moved it;
        // the other writes reach its proxies with the next replicated state.
        if let (Some(own), PhysicsOp::Impulse { .. }) = (self.own_writes.as_deref_mut(), op) {
            own.push(*op);
        }
    }
}
