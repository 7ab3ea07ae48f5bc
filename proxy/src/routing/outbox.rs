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
}

impl<'a> Outbox<'a> {
    pub(super) fn new(
        outbound: &'a mut Outbound<RoutedOp>,
        numbers: &'a mut Numbers,
        neighbours: &'a [ClusterId],
        tick: u64,
    ) -> Self {
        Self {
            outbound,
            numbers,
            neighbours,
            tick,
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
}
