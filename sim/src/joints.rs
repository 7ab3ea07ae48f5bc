//! Joints between entities this cluster owns (a joint across clusters is refused: affinity
//! must put joint partners in one cluster).

use std::collections::BTreeMap;

use rapier3d::prelude::*;

use crate::handle::PhysicsHandle;
use crate::wire::EntityId;

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

impl PhysicsHandle<'_> {
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
