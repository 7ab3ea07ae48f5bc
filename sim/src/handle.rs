//! What user code gets each tick: a [`TickContext`] to read and a [`PhysicsHandle`] to query and
//! write, both keyed by entity id.
//!
//! The handle is also the seam the proxy layer plugs into: a write on an entity this cluster
//! does not own goes to a [`WriteRouter`] instead of the world, and a joint between entities of
//! different owners is refused.

use rapier3d::prelude::*;

use crate::body::{self, Entry, StaleBounds};
use crate::contacts::ContactEvent;
use crate::entity::{BodyRole, EntityInfo};
use crate::error::SimError;
use crate::joints::{JointId, JointSpec, Joints};
use crate::router::{WriteOutcome, WriteRouter};
use crate::validate;
use crate::wire::{ClusterId, EntityId, EntityState, IdMap, PhysicsOp, Shape};

/// What user code may read this tick.
pub struct TickContext<'a> {
    pub(crate) cluster_id: ClusterId,
    pub(crate) tick: u64,
    pub(crate) entities: &'a IdMap<EntityId, Entry>,
    pub(crate) contacts: &'a [ContactEvent],
}

impl TickContext<'_> {
    /// This cluster.
    pub fn cluster_id(&self) -> ClusterId {
        self.cluster_id
    }

    /// The tick being run (steps taken so far).
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Every entity visible in this world (owned here or proxied), in a deterministic order.
    pub fn entities(&self) -> impl Iterator<Item = (EntityId, &EntityInfo)> {
        self.entities.iter().map(|(id, e)| (*id, &e.info))
    }

    /// What the world knows of one entity.
    pub fn entity(&self, id: EntityId) -> Option<&EntityInfo> {
        self.entities.get(&id).map(|e| &e.info)
    }

    /// Contacts that started or stopped in the last step.
    pub fn contacts(&self) -> &[ContactEvent] {
        self.contacts
    }
}

/// The first body a ray hits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// The entity hit.
    pub entity: EntityId,
    /// Distance along the ray, in units of the direction's length.
    pub toi: f32,
    /// The hit point, world space.
    pub point: [f32; 3],
    /// The surface normal at the hit point.
    pub normal: [f32; 3],
}

/// Entity-keyed reads, queries and writes on one cluster's world.
pub struct PhysicsHandle<'a> {
    pub(crate) cluster_id: ClusterId,
    pub(crate) world: &'a mut PhysicsWorld,
    pub(crate) entities: &'a IdMap<EntityId, Entry>,
    pub(crate) joints: &'a mut Joints,
    pub(crate) stale: &'a mut StaleBounds,
    /// Entities spawned by game code this tick, added to the world once it has run.
    pub(crate) spawned: &'a mut Vec<(EntityState, BodyRole)>,
    pub(crate) router: &'a mut dyn WriteRouter,
    /// `SimConfig::max_op_magnitude`.
    pub(crate) max_op_magnitude: f32,
    /// The world's registered shapes.
    pub(crate) catalog: &'a crate::shapes::ShapeCatalog,
}

impl PhysicsHandle<'_> {
    fn body(&self, id: EntityId) -> Result<&RigidBody, SimError> {
        let entry = self.entities.get(&id).ok_or(SimError::UnknownEntity(id))?;
        Ok(&self.world.bodies[entry.body])
    }

    /// The velocities of an entity owned elsewhere, as its owner replicated them last.
    fn replicated(&self, id: EntityId) -> Option<([f32; 3], [f32; 3])> {
        self.entities
            .get(&id)
            .filter(|e| e.info.owner != self.cluster_id)
            .map(|e| e.replicated)
    }

    /// Position of the body origin.
    pub fn translation(&self, id: EntityId) -> Result<[f32; 3], SimError> {
        Ok(self.body(id)?.translation().to_array())
    }

    /// Orientation `[x, y, z, w]`.
    pub fn rotation(&self, id: EntityId) -> Result<[f32; 4], SimError> {
        Ok(self.body(id)?.rotation().to_array())
    }

    /// Linear velocity: the body's, or for a proxy the one its owner replicated last.
    pub fn linvel(&self, id: EntityId) -> Result<[f32; 3], SimError> {
        match self.replicated(id) {
            Some((linvel, _)) => Ok(linvel),
            None => Ok(self.body(id)?.linvel().to_array()),
        }
    }

    /// Angular velocity: the body's, or for a proxy the one its owner replicated last.
    pub fn angvel(&self, id: EntityId) -> Result<[f32; 3], SimError> {
        match self.replicated(id) {
            Some((_, angvel)) => Ok(angvel),
            None => Ok(self.body(id)?.angvel().to_array()),
        }
    }

    /// The first body hit by the ray from `origin` along `direction`, up to `max_toi` times the
    /// direction's length, leaving out `exclude` (typically the shooter). Proxies are hit like
    /// any body, where they are now: bodies moved or added since the last step have their query
    /// bounds refreshed first (once; a tick without queries skips that work).
    pub fn raycast(
        &mut self,
        origin: [f32; 3],
        direction: [f32; 3],
        max_toi: f32,
        exclude: Option<EntityId>,
    ) -> Option<RayHit> {
        let finite = |v: [f32; 3]| v.iter().all(|c| c.is_finite());
        if !finite(origin) || !finite(direction) || !max_toi.is_finite() || max_toi < 0.0 {
            return None;
        }
        body::refresh_bounds(self.world, self.stale);
        let excluded = exclude
            .and_then(|id| self.entities.get(&id))
            .map(|e| e.body);
        let mut filter = QueryFilter::default();
        if let Some(body) = excluded {
            filter = filter.exclude_rigid_body(body);
        }
        let ray = Ray::new(Vector::from_array(origin), Vector::from_array(direction));
        let (collider, hit) = self
            .world
            .cast_ray_and_get_normal(&ray, max_toi, true, filter)?;
        let entity = EntityId::from_u128(self.world.colliders.get(collider)?.user_data);
        Some(RayHit {
            entity,
            toi: hit.time_of_impact,
            point: ray.point_at(hit.time_of_impact).to_array(),
            normal: hit.normal.to_array(),
        })
    }

    /// The entities whose shapes intersect `shape` placed at `position` with `rotation`, in id
    /// order (none for a catalog shape this world has not registered).
    pub fn intersections_with_shape(
        &mut self,
        shape: &Shape,
        position: [f32; 3],
        rotation: [f32; 4],
    ) -> Vec<EntityId> {
        body::refresh_bounds(self.world, self.stale);
        let Ok(shape) = self.catalog.resolve(shape) else {
            return Vec::new();
        };
        let pose = body::pose_of(position, rotation);
        let mut hits: Vec<EntityId> = self
            .world
            .intersect_shape(pose, &*shape, QueryFilter::default())
            .map(|(_, c)| EntityId::from_u128(c.user_data))
            .collect();
        hits.sort_unstable();
        hits
    }

    /// Applies `op` here if the target is owned here, else hands it to the router. Invalid ops
    /// (NaN, infinity, a value beyond `SimConfig::max_op_magnitude`, unknown entity) change
    /// nothing and route nothing.
    pub fn write(&mut self, op: PhysicsOp) -> Result<WriteOutcome, SimError> {
        validate::op(&op, self.max_op_magnitude)?;
        let entry = self
            .entities
            .get(&op.target())
            .ok_or(SimError::UnknownEntity(op.target()))?;
        if entry.info.owner == self.cluster_id {
            body::apply_op(self.world, self.stale, entry, &op);
            self.router.applied(&op);
            Ok(WriteOutcome::Applied)
        } else if entry.info.owner == ClusterId::SCENERY {
            Err(SimError::Scenery(op.target()))
        } else {
            self.router.route(entry.info.owner, op)?;
            Ok(WriteOutcome::Routed)
        }
    }

    /// Adds an impulse at the centre of mass.
    pub fn apply_impulse(
        &mut self,
        target: EntityId,
        impulse: [f32; 3],
    ) -> Result<WriteOutcome, SimError> {
        self.write(PhysicsOp::Impulse { target, impulse })
    }

    /// Adds a force for the next step.
    pub fn apply_force(
        &mut self,
        target: EntityId,
        force: [f32; 3],
    ) -> Result<WriteOutcome, SimError> {
        self.write(PhysicsOp::Force { target, force })
    }

    /// Adds an angular impulse.
    pub fn apply_torque_impulse(
        &mut self,
        target: EntityId,
        torque_impulse: [f32; 3],
    ) -> Result<WriteOutcome, SimError> {
        self.write(PhysicsOp::TorqueImpulse {
            target,
            torque_impulse,
        })
    }

    /// Teleports the body.
    pub fn set_translation(
        &mut self,
        target: EntityId,
        translation: [f32; 3],
    ) -> Result<WriteOutcome, SimError> {
        self.write(PhysicsOp::SetTranslation {
            target,
            translation,
        })
    }

    /// Sets the linear velocity.
    pub fn set_linvel(
        &mut self,
        target: EntityId,
        linvel: [f32; 3],
    ) -> Result<WriteOutcome, SimError> {
        self.write(PhysicsOp::SetLinvel { target, linvel })
    }

    /// Sets the angular velocity.
    pub fn set_angvel(
        &mut self,
        target: EntityId,
        angvel: [f32; 3],
    ) -> Result<WriteOutcome, SimError> {
        self.write(PhysicsOp::SetAngvel { target, angvel })
    }

    /// Wakes the body.
    pub fn wake(&mut self, target: EntityId) -> Result<WriteOutcome, SimError> {
        self.write(PhysicsOp::Wake { target })
    }

    /// Spawns an entity this cluster owns, with `role` (dynamic for what it simulates), from
    /// game code: a shot fired, debris. It is checked now (finite, a unit rotation, a shape with
    /// a size, an id not in this world) and added to the world once this tick's game code has
    /// run, before the step: reads and queries of this tick do not see it yet, and its first
    /// replication frame is this tick's. Its state's `cluster_id` is set to this cluster.
    pub fn spawn(&mut self, state: &EntityState, role: BodyRole) -> Result<(), SimError> {
        validate::state(state)?;
        validate::against_catalog(state, role, self.catalog)?;
        if self.entities.contains_key(&state.id)
            || self.spawned.iter().any(|(s, _)| s.id == state.id)
        {
            return Err(SimError::DuplicateEntity(state.id));
        }
        let state = EntityState {
            cluster_id: self.cluster_id,
            ..*state
        };
        self.spawned.push((state, role));
        Ok(())
    }

    /// Puts the body to sleep.
    pub fn sleep(&mut self, target: EntityId) -> Result<WriteOutcome, SimError> {
        self.write(PhysicsOp::Sleep { target })
    }

    /// Joins two entities. Returns `None` unless both are in this world and owned by this
    /// cluster: joints across clusters are refused (affinity must co-locate joint partners),
    /// and so are joints with invalid (non-finite) anchors or axis.
    pub fn create_joint(&mut self, a: EntityId, b: EntityId, spec: JointSpec) -> Option<JointId> {
        let owned = |id: EntityId| {
            self.entities
                .get(&id)
                .filter(|e| e.info.owner == self.cluster_id)
                .map(|e| e.body)
        };
        let (body_a, body_b) = (owned(a)?, owned(b)?);
        if a == b {
            return None;
        }
        self.joints
            .create(&mut self.world.impulse_joints, body_a, body_b, spec)
    }

    /// Removes a joint; returns whether it existed.
    pub fn remove_joint(&mut self, joint: JointId) -> bool {
        self.joints.remove(&mut self.world.impulse_joints, joint)
    }
}
