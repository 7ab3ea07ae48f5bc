//! What the world knows of an entity besides its body: its [`BodyRole`] and [`EntityInfo`].

use rapier3d::prelude::RigidBodyType;

use crate::wire::{BodySpec, ClusterId};

/// How a body takes part in the simulation. A body changes role in place, keeping its handle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BodyRole {
    /// Simulated: forces, impulses and contacts move it. Only the authority has these.
    Dynamic,
    /// Does not move unless set; other bodies collide with it. The default proxy.
    Fixed,
    /// Moves with the velocity it is given; contacts do not push it.
    KinematicVelocityBased,
    /// Moves to the pose it is given by the next step; contacts do not push it.
    KinematicPositionBased,
}

impl BodyRole {
    pub(crate) fn rapier(self) -> RigidBodyType {
        match self {
            BodyRole::Dynamic => RigidBodyType::Dynamic,
            BodyRole::Fixed => RigidBodyType::Fixed,
            BodyRole::KinematicVelocityBased => RigidBodyType::KinematicVelocityBased,
            BodyRole::KinematicPositionBased => RigidBodyType::KinematicPositionBased,
        }
    }
}

/// What the world knows of an entity besides its body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EntityInfo {
    /// The entity's owner — its authority, the one cluster that simulates it and applies writes
    /// on it — as this world last learned it (`EntityState::cluster_id` on the wire).
    pub owner: ClusterId,
    /// How many times its authority had moved when this world last learned it (see
    /// `EntityState::epoch`).
    pub epoch: u32,
    /// The body's current role.
    pub role: BodyRole,
    /// Shape, density, CCD.
    pub body: BodySpec,
}
