//! What user code gets each tick: a [`TickContext`] to read and a [`PhysicsHandle`] to query and
//! write, both keyed by entity id.
//!
//! The handle is also the seam the proxy layer plugs into: a write on an entity this cluster
//! does not own goes to a [`WriteRouter`] instead of the world, and a joint between entities of
//! different owners is refused.

use std::collections::BTreeMap;

use rapier3d::prelude::*;

use crate::body::{self, Entry, StaleBounds};
use crate::cluster_sim::EntityInfo;
use crate::contacts::ContactEvent;
use crate::error::SimError;
use crate::validate;
use crate::wire::{ClusterId, EntityId, IdMap, PhysicsOp, Shape};

/// Takes writes on entities owned by other clusters. The proxy layer implements it to queue the
/// op for the owner; [`LocalOnly`] refuses them.
pub trait WriteRouter {
    /// Takes `op`, aimed at an entity whose authority is `owner`.
    fn route(&mut self, owner: ClusterId, op: PhysicsOp) -> Result<(), SimError>;
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

/// A joint between two entities, anchored in each body's local frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointSpec {
    /// No relative motion.
    Fixed {
        /// Anchor on the first body.
        anchor_a: [f32; 3],
        /// Anchor on the second body.
        anchor_b: [f32; 3],
    },
    /// A ball joint: the anchors stay together, rotation is free.
    Spherical {
        /// Anchor on the first body.
        anchor_a: [f32; 3],
        /// Anchor on the second body.
        anchor_b: [f32; 3],
    },
    /// A hinge about `axis`.
    Revolute {
        /// Hinge axis (need not be normalised).
        axis: [f32; 3],
        /// Anchor on the first body.
        anchor_a: [f32; 3],
        /// Anchor on the second body.
        anchor_b: [f32; 3],
    },
}

/// A joint made by [`PhysicsHandle::create_joint`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct JointId(u64);

/// The joints of a world, by seam id.
#[derive(Default)]
pub(crate) struct Joints {
    next: u64,
    handles: BTreeMap<JointId, (ImpulseJointHandle, RigidBodyHandle, RigidBodyHandle)>,
}

impl Joints {
    /// Forgets the joints of a body being removed (Rapier removes them with it).
    pub(crate) fn forget_body(&mut self, body: RigidBodyHandle) {
        self.handles.retain(|_, (_, a, b)| *a != body && *b != body);
    }
}

/// Entity-keyed reads, queries and writes on one cluster's world.
pub struct PhysicsHandle<'a> {
    pub(crate) cluster_id: ClusterId,
    pub(crate) world: &'a mut PhysicsWorld,
    pub(crate) entities: &'a IdMap<EntityId, Entry>,
    pub(crate) joints: &'a mut Joints,
    pub(crate) stale: &'a mut StaleBounds,
    pub(crate) router: &'a mut dyn WriteRouter,
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
            .filter(|e| e.info.cluster_id != self.cluster_id)
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
    /// order.
    pub fn intersections_with_shape(
        &mut self,
        shape: &Shape,
        position: [f32; 3],
        rotation: [f32; 4],
    ) -> Vec<EntityId> {
        body::refresh_bounds(self.world, self.stale);
        let collider = body::collider_for(shape).build();
        let pose = body::pose_of(position, rotation);
        let mut hits: Vec<EntityId> = self
            .world
            .intersect_shape(pose, collider.shape(), QueryFilter::default())
            .map(|(_, c)| EntityId::from_u128(c.user_data))
            .collect();
        hits.sort_unstable();
        hits
    }

    /// Applies `op` here if the target is owned here, else hands it to the router. Invalid ops
    /// (NaN, infinity, unknown entity) change nothing and route nothing.
    pub fn write(&mut self, op: PhysicsOp) -> Result<WriteOutcome, SimError> {
        validate::op(&op)?;
        let entry = self
            .entities
            .get(&op.target())
            .ok_or(SimError::UnknownEntity(op.target()))?;
        if entry.info.cluster_id == self.cluster_id {
            body::apply_op(self.world, self.stale, entry, &op);
            Ok(WriteOutcome::Applied)
        } else if entry.info.cluster_id == ClusterId::SCENERY {
            Err(SimError::Scenery(op.target()))
        } else {
            self.router.route(entry.info.cluster_id, op)?;
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
                .filter(|e| e.info.cluster_id == self.cluster_id)
                .map(|e| e.body)
        };
        let (body_a, body_b) = (owned(a)?, owned(b)?);
        if a == b {
            return None;
        }
        let point = |v: [f32; 3]| {
            v.iter()
                .all(|c| c.is_finite())
                .then(|| Vector::from_array(v))
        };
        let joint: GenericJoint = match spec {
            JointSpec::Fixed { anchor_a, anchor_b } => FixedJointBuilder::new()
                .local_anchor1(point(anchor_a)?)
                .local_anchor2(point(anchor_b)?)
                .into(),
            JointSpec::Spherical { anchor_a, anchor_b } => SphericalJointBuilder::new()
                .local_anchor1(point(anchor_a)?)
                .local_anchor2(point(anchor_b)?)
                .into(),
            JointSpec::Revolute {
                axis,
                anchor_a,
                anchor_b,
            } => {
                let axis = point(axis)?.try_normalize()?;
                RevoluteJointBuilder::new(axis)
                    .local_anchor1(point(anchor_a)?)
                    .local_anchor2(point(anchor_b)?)
                    .into()
            }
        };
        let handle = self
            .world
            .impulse_joints
            .insert(body_a, body_b, joint, true);
        let id = JointId(self.joints.next);
        self.joints.next += 1;
        self.joints.handles.insert(id, (handle, body_a, body_b));
        Some(id)
    }

    /// Removes a joint; returns whether it existed.
    pub fn remove_joint(&mut self, joint: JointId) -> bool {
        match self.joints.handles.remove(&joint) {
            Some((handle, _, _)) => self.world.impulse_joints.remove(handle, true).is_some(),
            None => false,
        }
    }
}
