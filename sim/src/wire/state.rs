//! What replication carries: an entity's state ([`EntityState`]: pose, velocities, the body it
//! is) and a tick's frame of them ([`ReplicationFrame`]).

use serde::{Deserialize, Serialize};

use super::ids::{ClusterId, EntityId};

/// A collision shape, as small as a proxy needs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Shape {
    /// A sphere.
    Ball {
        /// Radius in metres.
        radius: f32,
    },
    /// A box.
    Cuboid {
        /// Half the size along x, y, z, in metres.
        half_extents: [f32; 3],
    },
    /// A capsule along the local y axis.
    Capsule {
        /// Half the length of the straight part, in metres.
        half_height: f32,
        /// Radius in metres.
        radius: f32,
    },
}

/// How an entity's owner moves its body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Motion {
    /// Simulated as a dynamic body. Only a proxy of a simulated entity takes part in
    /// contacts with the entity's mass (see `seam_sim::coupling`).
    #[default]
    Simulated,
    /// Moved by its owner through its velocity (a kinematic body: a platform, an elevator, a
    /// door). Its proxies move with that velocity whatever the proxy mode, so bodies resting on
    /// it are carried as in one world, and a new owner keeps it kinematic with its velocity.
    Kinematic,
    /// Does not move (a Fixed body).
    Still,
}

impl Motion {
    /// The motion of an owned body of `role`.
    pub fn of(role: crate::BodyRole) -> Self {
        match role {
            crate::BodyRole::Dynamic => Motion::Simulated,
            crate::BodyRole::Fixed => Motion::Still,
            crate::BodyRole::KinematicVelocityBased | crate::BodyRole::KinematicPositionBased => {
                Motion::Kinematic
            }
        }
    }

    /// The role its owner gives a body of this motion (a kinematic one velocity-based, with
    /// the velocity it had).
    pub fn owner_role(self) -> crate::BodyRole {
        match self {
            Motion::Simulated => crate::BodyRole::Dynamic,
            Motion::Kinematic => crate::BodyRole::KinematicVelocityBased,
            Motion::Still => crate::BodyRole::Fixed,
        }
    }
}

/// The spec of the body an entity is, beyond its pose: shape, density, whether it needs
/// continuous collision detection, and how its owner moves it. It travels with every state so
/// a cluster that takes authority over an entity simulates it with the same mass and CCD as
/// the previous owner, and moves it the same way.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BodySpec {
    /// The collision shape.
    pub shape: Shape,
    /// Density in kg/m³ (mass = density × volume).
    pub density: f32,
    /// Continuous collision detection, for fast bodies that must not tunnel through thin ones.
    pub ccd: bool,
    /// How its owner moves it; an adopter or new owner gives the body back the role it had
    /// (see [`Motion::owner_role`]).
    pub motion: Motion,
}

/// One entity's replicated state: the spine every neighbour receives. Its wire form is a
/// fixed-layout record (see [`ReplicationView`](super::ReplicationView)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EntityState {
    /// The entity.
    pub id: EntityId,
    /// The entity's **owner** (its authority): the cluster that simulates it and applies writes
    /// on it. The design and its users know the field as `cluster_id`, so the wire keeps the
    /// name; it never means the cluster holding the state. Changing it moves the entity.
    pub cluster_id: ClusterId,
    /// The authority's tick this state is from.
    pub tick: u64,
    /// How many times the entity's authority has moved: each hand-off increments it. A state
    /// older than what a cluster knows of the entity (a hand-off repeated after the entity
    /// moved on) is not news and changes nothing.
    pub epoch: u32,
    /// World position of the body origin, metres.
    pub position: [f32; 3],
    /// Orientation as a unit quaternion `[x, y, z, w]`.
    pub rotation: [f32; 4],
    /// Linear velocity, m/s.
    pub linvel: [f32; 3],
    /// Angular velocity, rad/s.
    pub angvel: [f32; 3],
    /// Shape, density, CCD.
    pub body: BodySpec,
}

impl EntityState {
    /// The entity's owner (the wire's `cluster_id`).
    pub fn owner(&self) -> ClusterId {
        self.cluster_id
    }

    /// Position, rotation, linear and angular velocity as raw IEEE 754 bits, to compare worlds
    /// exactly (determinism checks).
    pub fn motion_bits(&self) -> [u32; 13] {
        let mut bits = [0u32; 13];
        let values = self
            .position
            .iter()
            .chain(&self.rotation)
            .chain(&self.linvel)
            .chain(&self.angvel);
        for (slot, value) in bits.iter_mut().zip(values) {
            *slot = value.to_bits();
        }
        bits
    }
}

/// What one cluster publishes on `replication:<cluster_id>` each tick. Its wire form is
/// fixed-layout records read in place (see [`ReplicationView`](super::ReplicationView)), not postcard.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplicationFrame {
    /// The publishing cluster.
    pub from: ClusterId,
    /// Its tick.
    pub tick: u64,
    /// The states of the entities it owns (and, in the tick of a hand-off, the entity it gives
    /// away, already naming its new authority).
    pub states: Vec<EntityState>,
}
