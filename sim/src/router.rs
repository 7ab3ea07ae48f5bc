//! Where a write on an entity owned elsewhere goes: the [`WriteRouter`] the proxy layer plugs
//! in, or [`LocalOnly`] for a world that stands alone.

use crate::error::SimError;
use crate::wire::{ClusterId, PhysicsOp};

/// Takes writes on entities owned by other clusters. The proxy layer implements it to queue the
/// op for the owner; [`LocalOnly`] refuses them.
pub trait WriteRouter {
    /// Takes `op`, aimed at an entity whose authority is `owner`.
    fn route(&mut self, owner: ClusterId, op: PhysicsOp) -> Result<(), SimError>;

    /// Notes `op`, just applied to a body this cluster owns (the proxy layer tells its
    /// neighbours, whose proxies of the body should move with it). Does nothing by default.
    fn applied(&mut self, op: &PhysicsOp) {
        let _ = op;
    }
}

/// A router for a world that stands alone: every write on a remote-owned entity is refused with
/// [`SimError::NotOwned`].
#[derive(Debug, Default, Clone, Copy)]
pub struct LocalOnly;

impl WriteRouter for LocalOnly {
    fn route(&mut self, owner: ClusterId, op: PhysicsOp) -> Result<(), SimError> {
        Err(SimError::NotOwned {
            entity: op.target(),
            owner,
        })
    }
}

/// What happened to a write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WriteOutcome {
    /// Applied to this world (the entity is owned here).
    Applied,
    /// Handed to the router for the entity's owner.
    Routed,
}
