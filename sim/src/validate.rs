//! Checks on values that come from user code or from the wire, before they reach Rapier.

use crate::error::SimError;
use crate::wire::{BodySpec, EntityId, EntityState, PhysicsOp, Shape};

/// Largest quaternion norm error accepted (rotations are renormalised after the check).
const UNIT_TOLERANCE: f32 = 1e-3;

/// Checks that `value` is finite.
pub(crate) fn finite(
    entity: EntityId,
    what: &'static str,
    value: [f32; 3],
) -> Result<(), SimError> {
    if value.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(SimError::NonFinite {
            entity,
            what,
            value,
        })
    }
}

/// Checks an op's vector: finite, and no component beyond `bound`.
pub(crate) fn op(op: &PhysicsOp, bound: f32) -> Result<(), SimError> {
    let Some(v) = op.vector() else {
        return Ok(());
    };
    finite(op.target(), op.name(), v)?;
    if v.iter().any(|c| c.abs() > bound) {
        return Err(SimError::BeyondBound {
            entity: op.target(),
            what: op.name(),
            value: v,
            bound,
        });
    }
    Ok(())
}

/// Checks a shape descriptor.
pub(crate) fn body_spec(entity: EntityId, body: &BodySpec) -> Result<(), SimError> {
    let positive = |x: f32| x.is_finite() && x > 0.0;
    let ok = match body.shape {
        Shape::Ball { radius } => positive(radius),
        Shape::Cuboid { half_extents } => half_extents.iter().all(|&h| positive(h)),
        Shape::Capsule {
            half_height,
            radius,
        } => positive(radius) && half_height.is_finite() && half_height >= 0.0,
    };
    if !ok {
        return Err(SimError::BadShape {
            entity,
            reason: "dimensions must be positive and finite",
        });
    }
    if !positive(body.density) {
        return Err(SimError::BadShape {
            entity,
            reason: "density must be positive and finite",
        });
    }
    Ok(())
}

/// Checks a whole state: finite pose and velocities, a unit rotation, a shape with positive
/// finite sizes and density — what spawning needs. The proxy layer checks every received state
/// with it, modelled or not.
pub fn check_state(state: &EntityState) -> Result<(), SimError> {
    motion(state)?;
    body_spec(state.id, &state.body)
}

pub(crate) use check_state as state;

/// Checks a state's pose and velocities.
pub(crate) fn motion(state: &EntityState) -> Result<(), SimError> {
    let id = state.id;
    finite(id, "position", state.position)?;
    finite(id, "linvel", state.linvel)?;
    finite(id, "angvel", state.angvel)?;
    let [x, y, z, w] = state.rotation;
    let norm = (x * x + y * y + z * z + w * w).sqrt();
    if !norm.is_finite() || (norm - 1.0).abs() > UNIT_TOLERANCE {
        return Err(SimError::BadRotation {
            entity: id,
            rotation: state.rotation,
        });
    }
    Ok(())
}
