//! What reaches a [`ClusterSim`] from outside its steps: the shapes of the world's catalog, and
//! replicated states of its bodies.

use super::ClusterSim;
use crate::body;
use crate::coupling;
use crate::entity::BodyRole;
use crate::error::SimError;
use crate::shapes::{ShapeCatalog, ShapeDef};
use crate::validate;
use crate::wire::{EntityId, EntityState};

impl ClusterSim {
    /// Registers a shape too large to travel with every state (see [`ShapeCatalog`]); every
    /// cluster of a world registers the same ones. Returns the [`Shape`](crate::wire::Shape)
    /// that names it.
    pub fn register_shape(&mut self, def: ShapeDef) -> Result<crate::wire::Shape, SimError> {
        self.catalog.add(def)
    }

    /// The shapes registered here.
    pub fn shapes(&self) -> &ShapeCatalog {
        &self.catalog
    }

    /// Moves a body to a replicated state as its role allows: Fixed and dynamic bodies are set
    /// to the pose and velocity; a proxy that is kinematic velocity-based gets the velocity
    /// that reaches the pose in one step; a kinematic position-based body is moved there by the
    /// next step. A kinematic velocity-based body this cluster owns (a platform taken over or
    /// adopted) is set to the pose and velocity: the state is its own. The authority is taken
    /// from the state too. Queries see the new pose at once.
    pub fn apply_state(&mut self, state: &EntityState) -> Result<(), SimError> {
        // The body keeps its shape, so only the motion is checked.
        validate::motion(state)?;
        let index = self.index_of(state.id)?;
        let (_, entry) = self
            .entities
            .get_index_mut(index)
            .ok_or(SimError::UnknownEntity(state.id))?;
        entry.info.owner = state.cluster_id;
        entry.info.epoch = state.epoch;
        let owned = state.cluster_id == self.config.cluster_id;
        let behind = coupling::ticks_behind(self.tick, state.tick);
        // A coupled proxy is stepped from here with this world's bodies: its pose is taken to
        // this world's tick (a staggered neighbour's frame can be from the step this world is
        // about to take).
        let coupled = !owned && entry.info.role == BodyRole::Dynamic;
        let state = if coupled {
            coupling::carried(state, behind, self.config.dt)
        } else {
            *state
        };
        body::apply_state(
            &mut self.world,
            &mut self.stale,
            entry,
            &state,
            self.config.dt,
            owned,
        );
        // A Fixed proxy stands where the state put it: as of the state's tick.
        entry.posed_tick = if entry.info.role == BodyRole::Fixed {
            self.tick.saturating_add_signed(-behind)
        } else {
            self.tick
        };
        Ok(())
    }

    /// Where `id` is in the entity map. Replicated states arrive in the order their owner lists
    /// them, which is the order their proxies were spawned in, so the entry after the last one
    /// found is tried before hashing: in that pattern the lookup reads the next entry instead
    /// of a cache-cold hash bucket.
    fn index_of(&mut self, id: EntityId) -> Result<usize, SimError> {
        let hint = self.next_index;
        let index = match self.entities.get_index(hint) {
            Some((key, _)) if *key == id => hint,
            _ => self
                .entities
                .get_index_of(&id)
                .ok_or(SimError::UnknownEntity(id))?,
        };
        self.next_index = index + 1;
        Ok(index)
    }
}
