//! What replication carries: an entity's state ([`EntityState`]: pose, velocities, the body it
//! is) and a tick's frame of them ([`ReplicationFrame`]).

use serde::{Deserialize, Serialize};

use super::ids::{ClusterId, EntityId};

/// A collision shape, as small as a proxy needs: a primitive by its sizes, or a shape of the
/// world's [`ShapeCatalog`](crate::ShapeCatalog) (convex hull, compound, triangle mesh,
/// heightfield) by its content hash, which every cluster of the world registers itself: the
/// shape's points travel once, with the catalog, never per tick.
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
    /// A shape of the catalog.
    Catalog {
        /// Its content hash.
        id: ShapeId,
        /// The radius of a sphere about the body origin holding the whole shape, metres (what
        /// interest and bounds need without the catalog).
        bound: f32,
    },
}

/// A catalog shape's content hash: the first 8 bytes of the BLAKE3 hash of its definition, so
/// two clusters naming the same id mean the same points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct ShapeId(pub u64);

impl std::fmt::Display for ShapeId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:016x}", self.0)
    }
}

/// What a body's surface is like and how it loses motion.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Friction coefficient (Rapier's default 0.5; the two bodies' are averaged).
    pub friction: f32,
    /// Restitution: 0 no bounce, 1 a perfect one (the two bodies' are averaged).
    pub restitution: f32,
    /// Linear damping, 1/s: the fraction of linear velocity lost per second, roughly.
    pub linear_damping: f32,
    /// Angular damping, 1/s.
    pub angular_damping: f32,
}

impl Default for Material {
    /// Rapier's defaults: friction 0.5, no bounce, no damping.
    fn default() -> Self {
        Self {
            friction: 0.5,
            restitution: 0.0,
            linear_damping: 0.0,
            angular_damping: 0.0,
        }
    }
}

/// Collision groups: two bodies meet when each one's `memberships` share a bit with the
/// other's `filter` (Rapier's `InteractionGroups`, tested both ways).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Groups {
    /// The groups the body is in (one bit each).
    pub memberships: u32,
    /// The groups it meets.
    pub filter: u32,
}

impl Default for Groups {
    /// In every group, meeting every group.
    fn default() -> Self {
        Self {
            memberships: u32::MAX,
            filter: u32::MAX,
        }
    }
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
/// continuous collision detection, how its owner moves it, its material, collision groups and
/// whether it is a sensor. It travels with every state (once per distinct spec a frame) so a
/// neighbour's proxy meets bodies as the entity does, and a cluster that takes authority over
/// an entity simulates it with the same mass, surface and CCD as the previous owner, and moves
/// it the same way. Build one with [`BodySpec::new`] and its setters.
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
    /// Friction, restitution, damping.
    pub material: Material,
    /// Which bodies it meets.
    pub groups: Groups,
    /// A sensor: it pushes nothing and is pushed by nothing, and reports bodies entering and
    /// leaving it as contacts (started / stopped), routed to owners as contacts are.
    pub sensor: bool,
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
    /// The publishing pod's incarnation: when it claimed its cluster (see
    /// `seam_transport::Transport::claim`). A receiver refuses frames of an incarnation older
    /// than one it has seen of the same cluster (a pod taken over, still publishing).
    pub incarnation: u64,
    /// The states of the entities it owns (and, in the tick of a hand-off, the entity it gives
    /// away, already naming its new authority).
    pub states: Vec<EntityState>,
}
