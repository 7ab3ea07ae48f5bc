//! Checks on values that come from user code or from the wire, before they reach Rapier.

use crate::entity::BodyRole;
use crate::error::SimError;
use crate::shapes::{ShapeCatalog, primitive_ok};
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

fn positive(x: f32) -> bool {
    x.is_finite() && x > 0.0
}

/// Checks a body spec: sizes, density and material.
pub(crate) fn body_spec(entity: EntityId, body: &BodySpec) -> Result<(), SimError> {
    let bad = |reason| Err(SimError::BadShape { entity, reason });
    let ok = match body.shape {
        Shape::Catalog { bound, .. } => positive(bound),
        _ => primitive_ok(&body.shape),
    };
    if !ok {
        return bad("dimensions must be positive and finite");
    }
    if !positive(body.density) {
        return bad("density must be positive and finite");
    }
    let m = body.material;
    let at_least_zero = |x: f32| x.is_finite() && x >= 0.0;
    if !(at_least_zero(m.friction)
        && at_least_zero(m.restitution)
        && at_least_zero(m.linear_damping)
        && at_least_zero(m.angular_damping))
    {
        return bad("friction, restitution and damping must be finite and at least 0");
    }
    Ok(())
}

/// Checks that a state's catalog shape is registered here and, for a body simulated here, has
/// a volume (a triangle mesh or heightfield is for scenery and bodies moved by their owner).
pub(crate) fn against_catalog(
    state: &EntityState,
    role: BodyRole,
    catalog: &ShapeCatalog,
) -> Result<(), SimError> {
    let Shape::Catalog { id, .. } = state.body.shape else {
        return Ok(());
    };
    let def = catalog.def(id).ok_or(SimError::UnknownShapeOf {
        entity: state.id,
        shape: id,
    })?;
    if role == BodyRole::Dynamic && !def.has_volume() {
        return Err(SimError::BadShape {
            entity: state.id,
            reason: "a triangle mesh or heightfield has no volume: it is for scenery and bodies \
                     moved by their owner (fixed, kinematic), not simulated ones",
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
