//! Joints between entities this cluster owns (a joint across clusters is refused: affinity
//! must put joint partners in one cluster).

use std::collections::BTreeMap;

use rapier3d::prelude::*;

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

/// A joint made by [`PhysicsHandle::create_joint`](crate::PhysicsHandle::create_joint).
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

    /// Joins `body_a` and `body_b` in `joints` as `spec` says; `None` if the spec's anchors or
    /// axis are not finite (or the axis has no length).
    pub(crate) fn create(
        &mut self,
        joints: &mut ImpulseJointSet,
        body_a: RigidBodyHandle,
        body_b: RigidBodyHandle,
        spec: JointSpec,
    ) -> Option<JointId> {
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
        let handle = joints.insert(body_a, body_b, joint, true);
        let id = JointId(self.next);
        self.next += 1;
        self.handles.insert(id, (handle, body_a, body_b));
        Some(id)
    }

    /// Removes a joint from `joints`; returns whether it existed.
    pub(crate) fn remove(&mut self, joints: &mut ImpulseJointSet, joint: JointId) -> bool {
        match self.handles.remove(&joint) {
            Some((handle, _, _)) => joints.remove(handle, true).is_some(),
            None => false,
        }
    }
}
