//! [`ClusterSim`]: one cluster's Rapier world, keyed by entity.

use rapier3d::prelude::*;

use crate::body::{self, Entry, StaleBounds};
use crate::config::SimConfig;
use crate::contacts::{ContactCollector, ContactEvent, read_impulse};
use crate::coupling::{self, CouplingChanges, SeamImpulse};
use crate::entity::{BodyRole, EntityInfo};
use crate::error::SimError;
use crate::handle::{PhysicsHandle, TickContext};
use crate::joints::Joints;
use crate::router::WriteRouter;
use crate::shapes::ShapeCatalog;
use crate::touching;
use crate::validate;
use crate::wire::{ClusterId, EntityId, EntityState, IdMap, Motion, PhysicsOp};

mod census;
mod states;

pub use census::PairCensus;

/// One cluster's world: a Rapier world and a map entity → body.
///
/// It knows nothing of other clusters beyond each entity's `cluster_id`; the proxy layer above
/// decides which role each body has and routes writes on entities owned elsewhere (see
/// [`WriteRouter`]).
pub struct ClusterSim {
    config: SimConfig,
    world: PhysicsWorld,
    entities: IdMap<EntityId, Entry>,
    joints: Joints,
    /// Bodies whose query bounds wait for the next query or step.
    stale: StaleBounds,
    /// Where the next replicated state's entity probably is (see `index_of`).
    next_index: usize,
    tick: u64,
    collector: ContactCollector,
    contacts: Vec<ContactEvent>,
    /// Entities game code spawned through the handle, added once its code has run.
    spawned: Vec<(EntityState, BodyRole)>,
    /// The shapes registered here (see [`ShapeCatalog`]).
    catalog: ShapeCatalog,
}

impl ClusterSim {
    /// An empty world.
    pub fn new(config: SimConfig) -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = Vector::from_array(config.gravity);
        world.integration_parameters.dt = config.dt;
        world.integration_parameters.normalized_max_linear_velocity =
            config.max_linear_velocity / world.integration_parameters.length_unit;
        Self {
            config,
            world,
            entities: IdMap::default(),
            joints: Joints::default(),
            stale: StaleBounds::new(),
            next_index: 0,
            tick: 0,
            collector: ContactCollector::default(),
            contacts: Vec::new(),
            spawned: Vec::new(),
            catalog: ShapeCatalog::default(),
        }
    }

    /// This cluster's id.
    pub fn cluster_id(&self) -> ClusterId {
        self.config.cluster_id
    }

    /// The settings the world was made with.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// Steps taken so far.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Whether the entity is in this world.
    pub fn contains(&self, id: EntityId) -> bool {
        self.entities.contains_key(&id)
    }

    /// What the world knows of an entity. Tries the entry after the last one posed before
    /// hashing, as [`Self::apply_state`] does: reconciling a frame reads each proxy's entry
    /// just before posing it, in the order they were spawned.
    pub fn info(&self, id: EntityId) -> Option<&EntityInfo> {
        match self.entities.get_index(self.next_index) {
            Some((key, entry)) if *key == id => Some(&entry.info),
            _ => self.entities.get(&id).map(|e| &e.info),
        }
    }

    /// Every entity in the world, in the order they were added (a despawn moves the last one
    /// into the gap): deterministic for the same history.
    pub fn entities(&self) -> impl Iterator<Item = (EntityId, &EntityInfo)> {
        self.entities.iter().map(|(id, e)| (*id, &e.info))
    }

    /// Every entity with its info, position and orientation `[x, y, z, w]`, in one pass (what
    /// a recording of the world needs each tick, without building whole states).
    pub fn poses(&self) -> impl Iterator<Item = (EntityId, &EntityInfo, [f32; 3], [f32; 4])> {
        self.entities.iter().filter_map(|(id, e)| {
            let body = self.world.bodies.get(e.body)?;
            Some((
                *id,
                &e.info,
                body.translation().to_array(),
                body.rotation().to_array(),
            ))
        })
    }

    /// Number of entities in the world.
    pub fn len(&self) -> usize {
        self.entities.len()
    }

    /// Whether the world is empty.
    pub fn is_empty(&self) -> bool {
        self.entities.is_empty()
    }

    /// The contacts that started or stopped in the last step.
    pub fn contacts(&self) -> &[ContactEvent] {
        &self.contacts
    }

    /// Keeps only the contacts of the last step that `keep` says to (the proxy layer drops a
    /// contact it has already surfaced from a neighbour's report).
    pub fn retain_contacts(&mut self, keep: impl FnMut(&ContactEvent) -> bool) {
        self.contacts.retain(keep);
    }

    /// Adds contact events that happened elsewhere (a neighbour's body touching this cluster's
    /// proxy there) to those of the last step, so user code sees them this tick.
    pub fn add_contacts(&mut self, events: impl IntoIterator<Item = ContactEvent>) {
        self.contacts.extend(events);
    }

    /// Adds an entity with `role`, at the state's pose and velocity.
    pub fn spawn(&mut self, state: &EntityState, role: BodyRole) -> Result<(), SimError> {
        validate::state(state)?;
        validate::against_catalog(state, role, &self.catalog)?;
        if self.entities.contains_key(&state.id) {
            return Err(SimError::DuplicateEntity(state.id));
        }
        let mut state = *state;
        if state.cluster_id == self.config.cluster_id {
            // What its neighbours are told of how it moves.
            state.body.motion = Motion::of(role);
        }
        let mut entry = body::insert(
            &mut self.world,
            &mut self.stale,
            &self.catalog,
            &state,
            role,
        )?;
        entry.posed_tick = self.tick;
        self.entities.insert(state.id, entry);
        Ok(())
    }

    /// Removes an entity; returns its last state. Joints attached to it go with it.
    pub fn despawn(&mut self, id: EntityId) -> Result<EntityState, SimError> {
        let state = self.state(id).ok_or(SimError::UnknownEntity(id))?;
        let entry = self
            .entities
            .swap_remove(&id)
            .ok_or(SimError::UnknownEntity(id))?;
        self.joints.forget_body(entry.body);
        self.world.remove_body(entry.body);
        Ok(state)
    }

    /// The entity's current state, as its replication would carry it. For a proxy, the pose
    /// is where its body is and the velocities are the ones its owner replicated last (a Fixed
    /// body has none of its own; a kinematic one has its dead-reckoning velocity).
    pub fn state(&self, id: EntityId) -> Option<EntityState> {
        let entry = self.entities.get(&id)?;
        let mut state = body::state_of(&self.world, id, entry, self.tick);
        if entry.info.owner != self.config.cluster_id {
            (state.linvel, state.angvel) = entry.replicated;
        }
        Some(state)
    }

    /// Whether the entity's body is asleep in this world: Rapier puts a body to sleep once it
    /// and everything it touches have been still for half a second, and steps it no more until
    /// something wakes it. `None` for an entity not here.
    pub fn is_asleep(&self, id: EntityId) -> Option<bool> {
        let entry = self.entities.get(&id)?;
        Some(self.world.bodies[entry.body].is_sleeping())
    }

    /// The current states of the entities this cluster owns, with their roles, in entity
    /// order: [`ClusterSim::state`] of each, in one pass.
    pub fn owned_states(&self) -> impl Iterator<Item = (EntityState, BodyRole)> + '_ {
        let me = self.config.cluster_id;
        (self.entities.iter())
            .filter(move |(_, entry)| entry.info.owner == me)
            .map(|(&id, entry)| {
                let state = body::state_of(&self.world, id, entry, self.tick);
                (state, entry.info.role)
            })
    }

    /// Changes a body's role in place, keeping its handle, pose and (where Rapier allows)
    /// velocity: a body made Fixed loses its velocity (Rapier zeroes it); a body made dynamic
    /// or kinematic keeps the velocity it has, and is woken.
    pub fn set_role(&mut self, id: EntityId, role: BodyRole) -> Result<(), SimError> {
        let entry = self
            .entities
            .get_mut(&id)
            .ok_or(SimError::UnknownEntity(id))?;
        self.world.bodies[entry.body].set_body_type(role.rapier(), true);
        entry.info.role = role;
        // Where it stands now is where the entity is (a body handed away, say).
        entry.posed_tick = self.tick;
        if entry.info.owner == self.config.cluster_id {
            entry.info.body.motion = Motion::of(role);
        }
        Ok(())
    }

    /// Couples the proxies that bodies simulated here may touch in the next step, and gives
    /// the others back `rest`, their mode's role (see `crate::coupling`). Call it just before
    /// [`Self::step`].
    pub fn couple_proxies(&mut self, rest: BodyRole) -> CouplingChanges {
        coupling::couple(
            &mut self.world,
            &mut self.entities,
            self.config.cluster_id,
            rest,
            self.tick,
            self.config.dt,
        )
    }

    /// Records a new authority for the entity and the epoch it came with (the proxy layer's
    /// authority flips).
    pub fn set_authority(
        &mut self,
        id: EntityId,
        cluster_id: ClusterId,
        epoch: u32,
    ) -> Result<(), SimError> {
        let entry = self
            .entities
            .get_mut(&id)
            .ok_or(SimError::UnknownEntity(id))?;
        let me = self.config.cluster_id;
        if entry.info.owner == me && cluster_id != me {
            // Handed away: reads of the proxy it becomes give the motion it left with.
            let body = &self.world.bodies[entry.body];
            entry.replicated = (body.linvel().to_array(), body.angvel().to_array());
        }
        entry.info.owner = cluster_id;
        entry.info.epoch = epoch;
        Ok(())
    }

    /// Applies a write to an entity in this world, whoever owns it (the owner applying routed
    /// ops uses this). Validated first: an invalid op changes nothing.
    pub fn apply_op(&mut self, op: &PhysicsOp) -> Result<(), SimError> {
        self.apply_op_late(op, 0)
    }

    /// As [`Self::apply_op`] for a write issued `missed` steps ago (a push routed from
    /// another cluster, applied a tick late): the motion those steps missed is added, so the
    /// body is where one world that applied it on time has it (see `body::apply_op_late`).
    pub fn apply_op_late(&mut self, op: &PhysicsOp, missed: u64) -> Result<(), SimError> {
        validate::op(op, self.config.max_op_magnitude)?;
        let entry = self
            .entities
            .get(&op.target())
            .ok_or(SimError::UnknownEntity(op.target()))?;
        body::apply_op_late(
            &mut self.world,
            &mut self.stale,
            entry,
            op,
            self.config.dt,
            missed,
        );
        Ok(())
    }

    /// Gives `target` an impulse that settles a contact across the seam this world's step has
    /// solved already (seam-proxy's settling): as [`Self::apply_op`] with an impulse, except
    /// that the body is woken only where the change of velocity is more than Rapier counts as
    /// still for sleep (see `body::apply_settling`). Validated first.
    pub fn apply_settling(&mut self, target: EntityId, impulse: [f32; 3]) -> Result<(), SimError> {
        validate::op(
            &PhysicsOp::Impulse { target, impulse },
            self.config.max_op_magnitude,
        )?;
        let entry = self
            .entities
            .get(&target)
            .ok_or(SimError::UnknownEntity(target))?;
        body::apply_settling(&mut self.world, entry, impulse);
        Ok(())
    }

    /// The tick context and the physics handle for user code, borrowing the world together.
    /// Writes on entities owned by another cluster go to `router`.
    pub fn tick_scope<'a>(
        &'a mut self,
        router: &'a mut dyn WriteRouter,
    ) -> (TickContext<'a>, PhysicsHandle<'a>) {
        let context = TickContext {
            cluster_id: self.config.cluster_id,
            tick: self.tick,
            entities: &self.entities,
            contacts: &self.contacts,
        };
        let handle = PhysicsHandle {
            cluster_id: self.config.cluster_id,
            world: &mut self.world,
            entities: &self.entities,
            joints: &mut self.joints,
            stale: &mut self.stale,
            spawned: &mut self.spawned,
            router,
            max_op_magnitude: self.config.max_op_magnitude,
            catalog: &self.catalog,
        };
        (context, handle)
    }

    /// Calls `user` with the tick context and physics handle (see [`Self::tick_scope`]).
    pub fn run_user<R>(
        &mut self,
        router: &mut dyn WriteRouter,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>) -> R,
    ) -> R {
        let (context, mut handle) = self.tick_scope(router);
        let result = user(&context, &mut handle);
        self.add_spawned();
        result
    }

    /// Adds what game code spawned through the handle (checked when it was asked for).
    fn add_spawned(&mut self) {
        for (state, role) in std::mem::take(&mut self.spawned) {
            // Refused only if game code also spawned the id directly meanwhile: the first stays.
            let _ = self.spawn(&state, role);
        }
    }

    /// Sets the tick count to `tick` (a world restarted into a running simulation carries on
    /// the others' count). The tick is the only thing it changes.
    pub fn resume_at(&mut self, tick: u64) {
        self.tick = tick;
    }

    /// The pairs of bodies touching now around the seam, each with its owner (see
    /// `crate::touching`): groups grown from each proxy that moves, up to `budget` bodies each.
    pub fn touching(&self, budget: usize) -> Vec<touching::Touching> {
        touching::around_proxies(&self.world, &self.entities, self.config.cluster_id, budget)
    }

    /// What the contacts of the last step between bodies simulated here and coupled proxies
    /// gave those bodies (see `crate::coupling`).
    pub fn seam_impulses(&self) -> Vec<SeamImpulse> {
        coupling::seam_impulses(&self.world, &self.entities, self.config.cluster_id)
    }

    /// Advances the world by one step and collects the contacts that started or stopped.
    pub fn step(&mut self) {
        // A handle taken with `tick_scope` adds its spawns here.
        self.add_spawned();
        // The step brings every moved body's bounds up to date itself.
        self.stale.clear();
        self.world.step_with_events(&(), &self.collector);
        self.collector.drain_into(&mut self.contacts);
        for contact in &mut self.contacts {
            if contact.started {
                read_impulse(&self.world, &self.entities, contact);
            }
        }
        self.tick += 1;
    }
}
