//! What game code adds to a cluster's world and changes in it: bodies it owns, scenery, the
//! shapes of the world's catalog, a body's role and owner, names for logs.

use seam_sim::wire::{ClusterId, EntityId, EntityState, Shape};
use seam_sim::{BodyRole, ShapeDef, SimError};

use super::Cluster;
use crate::error::ClusterError;
use crate::handoff;

impl Cluster {
    /// Adds an entity this cluster owns, with `role` (dynamic for what it simulates; Fixed or
    /// kinematic for scenery it moves itself). Its state's `cluster_id` is set to this cluster.
    pub fn spawn_owned(&mut self, state: &EntityState, role: BodyRole) -> Result<(), ClusterError> {
        let state = EntityState {
            cluster_id: self.id(),
            ..*state
        };
        self.sim.spawn(&state, role)?;
        Ok(())
    }

    /// Adds scenery: static level geometry (terrain, floors, walls) that every cluster loads
    /// itself. It is a Fixed body owned by no cluster ([`ClusterId::SCENERY`]): never
    /// replicated, never handed over, never adopted; writes on it are refused, and contacts
    /// with it are nobody's to report. Every cluster of a world must add the same scenery.
    pub fn spawn_scenery(&mut self, state: &EntityState) -> Result<(), ClusterError> {
        let state = EntityState {
            cluster_id: ClusterId::SCENERY,
            ..*state
        };
        self.sim.spawn(&state, BodyRole::Fixed)?;
        Ok(())
    }

    /// Registers a shape too large to travel with every state (a convex hull, a compound
    /// shape, a triangle mesh, a heightfield; see [`seam_sim::ShapeCatalog`]) and returns the
    /// [`Shape`] naming it by content hash, for the body specs that use it. Every cluster of a
    /// world registers the same shapes before bodies of them arrive: a state naming a shape
    /// this cluster never registered is refused (counted as a rejected state), never
    /// simulated as something else.
    pub fn register_shape(&mut self, def: ShapeDef) -> Result<Shape, ClusterError> {
        Ok(self.sim.register_shape(def)?)
    }

    /// Gives a body this cluster owns another role: dynamic (simulated), Fixed, or kinematic
    /// (moved by its velocity: a platform, a door). The change travels with its next state,
    /// so its proxies and any later owner move it the same way. A proxy's role is this
    /// cluster's to choose, not game code's: setting one is [`SimError::NotOwned`].
    pub fn set_role(&mut self, entity: EntityId, role: BodyRole) -> Result<(), ClusterError> {
        let owner = self
            .sim
            .info(entity)
            .ok_or(SimError::UnknownEntity(entity))?
            .owner;
        if owner == ClusterId::SCENERY {
            return Err(SimError::Scenery(entity).into());
        }
        if owner != self.id() {
            return Err(SimError::NotOwned { entity, owner }.into());
        }
        self.sim.set_role(entity, role)?;
        Ok(())
    }

    /// Names `entity` in this cluster's logs and reports (see
    /// [`ClusterConfig::entity_names`](crate::ClusterConfig::entity_names)): a body the game
    /// spawns, or a neighbour's it cares about. A name breaking the rule (1 to 64 printable
    /// characters) is refused.
    pub fn name_entity(&mut self, entity: EntityId, name: &str) -> Result<(), ClusterError> {
        crate::checks::entity_name(entity, name)?;
        self.config.entity_names.insert(entity, name.to_owned());
        Ok(())
    }

    /// Hands an entity this cluster owns to a neighbour. It happens at the next replication
    /// frame: that frame carries the entity's final pose and velocity with the new owner, this
    /// cluster turns its body into a proxy, and the new owner turns its proxy into the body.
    ///
    /// Refused ([`ClusterError::Transfer`], with the reason) while this cluster's transport is
    /// down (the frame would reach nobody), for a neighbour not heard from,
    /// taken for dead or gone, one that cannot model the entity (a catalog shape it lacks) or
    /// lately did not take it, and, where the world map holds the neighbour, one whose region
    /// grown by its spread the entity's extent does not reach: it holds no proxy to take over.
    pub fn transfer_authority(
        &mut self,
        entity: EntityId,
        to: ClusterId,
    ) -> Result<(), ClusterError> {
        handoff::check(&self.sim, &self.config, &self.neighbours, entity, to)?;
        if !self.transport.is_connected() {
            return Err(ClusterError::Transfer {
                entity,
                to,
                reason: "this cluster's transport is down: the frame that hands it would reach \
                         nobody",
            });
        }
        if self
            .handoffs
            .declined_by(entity, to, self.sim.tick(), &self.config)
        {
            return Err(ClusterError::Transfer {
                entity,
                to,
                reason: "the neighbour cannot model it (its shape is not registered there) or \
                         did not take it lately",
            });
        }
        self.handoffs.queue(entity, to);
        Ok(())
    }
}
