//! The one error type of `seam-sim`.

use crate::wire::EntityId;

/// Why a world operation was refused. A refused operation leaves the world unchanged.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// No entity with this id is in this world: neither owned here nor modelled as a proxy.
    /// A write reaches only what the cluster models (its region grown by the spread, the room
    /// around its own bodies, and what `Cluster::watch` adds): an entity owned elsewhere and
    /// out of sight cannot be written to from here.
    #[error(
        "entity {0} is not in this cluster's world: not owned here and not modelled (writes \
         reach what the cluster models: its region and spread, the room around its own bodies, \
         and what Cluster::watch adds)"
    )]
    UnknownEntity(EntityId),
    /// The entity is already in this world.
    #[error("entity {0} is already in this cluster's world")]
    DuplicateEntity(EntityId),
    /// A value is NaN or infinite.
    #[error("{what} of entity {entity} is not finite: {value:?}")]
    NonFinite {
        /// The entity written to.
        entity: EntityId,
        /// Which value.
        what: &'static str,
        /// The offending components.
        value: [f32; 3],
    },
    /// A write's value is beyond the bound (`SimConfig::max_op_magnitude`).
    #[error("{what} of entity {entity} is beyond the bound of {bound}: {value:?}")]
    BeyondBound {
        /// The entity written to.
        entity: EntityId,
        /// Which value.
        what: &'static str,
        /// The offending components.
        value: [f32; 3],
        /// The bound.
        bound: f32,
    },
    /// A state's rotation is not a unit quaternion.
    #[error("rotation of entity {entity} is not a unit quaternion: {rotation:?}")]
    BadRotation {
        /// The entity.
        entity: EntityId,
        /// The quaternion `[x, y, z, w]`.
        rotation: [f32; 4],
    },
    /// A shape dimension or density is not a positive finite number.
    #[error("shape of entity {entity} is invalid: {reason}")]
    BadShape {
        /// The entity.
        entity: EntityId,
        /// What is wrong.
        reason: &'static str,
    },
    /// A catalog shape cannot be built.
    #[error("catalog shape {id} is invalid: {reason}")]
    BadCatalogShape {
        /// Its content hash.
        id: crate::wire::ShapeId,
        /// What is wrong.
        reason: &'static str,
    },
    /// No shape with this content hash is registered here.
    #[error("no catalog shape {0} is registered in this world")]
    UnknownShape(crate::wire::ShapeId),
    /// An entity's body names a catalog shape this world has not registered: every cluster of
    /// a world must register the same shapes.
    #[error(
        "entity {entity} has catalog shape {shape}, which this world has not registered \
         (every cluster of a world registers the same shapes)"
    )]
    UnknownShapeOf {
        /// The entity.
        entity: EntityId,
        /// The shape's content hash.
        shape: crate::wire::ShapeId,
    },
    /// The write targets scenery, which no cluster owns and nothing moves.
    #[error("entity {0} is scenery: static, loaded by every cluster, owned by none")]
    Scenery(EntityId),
    /// The write targets an entity owned by another cluster and no router takes it.
    #[error("entity {entity} is owned by cluster {owner}; this handle cannot route writes to it")]
    NotOwned {
        /// The entity.
        entity: EntityId,
        /// Its authority.
        owner: crate::wire::ClusterId,
    },
}
