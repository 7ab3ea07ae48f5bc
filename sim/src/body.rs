//! Rapier bodies behind entities: creation from a state, reading a state back, writes.
//!
//! Every body has exactly one collider, attached at the body origin; both carry the entity id as
//! Rapier user data, so a collider found by a query or a contact names its entity directly.

use rapier3d::prelude::*;

use crate::entity::{BodyRole, EntityInfo};
use crate::error::SimError;
use crate::shapes::ShapeCatalog;
use crate::wire::{EntityId, EntityState, PhysicsOp};

/// Bodies moved or added outside a step whose query bounds are not refreshed yet. Queries
/// refresh them first ([`refresh_bounds`]); a step refreshes everything itself.
pub(crate) type StaleBounds = Vec<(RigidBodyHandle, ColliderHandle)>;

/// An entity's body in the world.
pub(crate) struct Entry {
    pub(crate) body: RigidBodyHandle,
    pub(crate) collider: ColliderHandle,
    pub(crate) info: EntityInfo,
    /// The linear and angular velocity the entity last came with (spawned or replicated): what
    /// reads of a proxy return, whatever its body does (a Fixed body has none; a kinematic one
    /// has the dead-reckoning velocity).
    pub(crate) replicated: ([f32; 3], [f32; 3]),
    /// This world's tick at which the body stood where the entity was: when it was spawned or
    /// set to a replicated state, or when coupling last let it go where the steps had put it.
    pub(crate) posed_tick: u64,
}

/// Contacts that produce events: Rapier's default (anything with a dynamic body) plus
/// kinematic–kinematic and kinematic–fixed, so a proxy touching a kinematic body owned here is
/// reported too.
fn collision_types() -> ActiveCollisionTypes {
    ActiveCollisionTypes::default()
        | ActiveCollisionTypes::KINEMATIC_KINEMATIC
        | ActiveCollisionTypes::KINEMATIC_FIXED
}

pub(crate) fn pose_of(position: [f32; 3], rotation: [f32; 4]) -> Pose {
    let [x, y, z, w] = rotation;
    Pose::from_parts(
        Vector::from_array(position),
        Rotation::from_xyzw(x, y, z, w).normalize(),
    )
}

/// Creates the body and collider of a (validated) state; a catalog shape must be in `catalog`.
pub(crate) fn insert(
    world: &mut PhysicsWorld,
    stale: &mut StaleBounds,
    catalog: &ShapeCatalog,
    state: &EntityState,
    role: BodyRole,
) -> Result<Entry, SimError> {
    let data = state.id.as_u128();
    let spec = &state.body;
    let body = RigidBodyBuilder::new(role.rapier())
        .pose(pose_of(state.position, state.rotation))
        .linvel(Vector::from_array(state.linvel))
        .angvel(Vector::from_array(state.angvel))
        .ccd_enabled(spec.ccd)
        .linear_damping(spec.material.linear_damping)
        .angular_damping(spec.material.angular_damping)
        .user_data(data);
    let groups = InteractionGroups::new(
        Group::from_bits_retain(spec.groups.memberships),
        Group::from_bits_retain(spec.groups.filter),
        InteractionTestMode::And,
    );
    let shape = catalog
        .resolve(&spec.shape)
        .map_err(|shape| SimError::UnknownShapeOf {
            entity: state.id,
            shape,
        })?;
    let collider = ColliderBuilder::new(shape)
        .density(spec.density)
        .friction(spec.material.friction)
        .restitution(spec.material.restitution)
        .collision_groups(groups)
        .sensor(spec.sensor)
        .user_data(data)
        .active_events(ActiveEvents::COLLISION_EVENTS)
        .active_collision_types(collision_types());
    let (body, collider) = world.insert(body, collider);
    let entry = Entry {
        body,
        collider,
        info: EntityInfo {
            owner: state.cluster_id,
            epoch: state.epoch,
            role,
            body: state.body,
        },
        replicated: (state.linvel, state.angvel),
        posed_tick: 0,
    };
    stale.push((entry.body, entry.collider));
    Ok(entry)
}

/// Reads an entity's state back.
pub(crate) fn state_of(
    world: &PhysicsWorld,
    id: EntityId,
    entry: &Entry,
    tick: u64,
) -> EntityState {
    let body = &world.bodies[entry.body];
    EntityState {
        id,
        cluster_id: entry.info.owner,
        tick,
        epoch: entry.info.epoch,
        position: body.translation().to_array(),
        rotation: body.rotation().to_array(),
        linvel: body.linvel().to_array(),
        angvel: body.angvel().to_array(),
        body: entry.info.body,
    }
}

/// Brings colliders and the query structure up to date with the bodies moved or added since the
/// last step, so raycasts and shape queries see them before the next step. Bodies removed
/// meanwhile are skipped.
pub(crate) fn refresh_bounds(world: &mut PhysicsWorld, stale: &mut StaleBounds) {
    for (body, collider_handle) in stale.drain(..) {
        let Some(body) = world.bodies.get(body) else {
            continue;
        };
        let pose = *body.position();
        if let Some(collider) = world.colliders.get_mut(collider_handle) {
            collider.set_position(pose);
            let aabb = collider.compute_aabb();
            world
                .broad_phase
                .set_aabb(&world.integration_parameters, collider_handle, aabb);
        }
    }
}

/// Moves a body to a (validated) replicated state as its role allows (see
/// `ClusterSim::apply_state`); `owned`: the state is of a body this cluster owns.
pub(crate) fn apply_state(
    world: &mut PhysicsWorld,
    stale: &mut StaleBounds,
    entry: &mut Entry,
    state: &EntityState,
    dt: f32,
    owned: bool,
) {
    entry.replicated = (state.linvel, state.angvel);
    let target = pose_of(state.position, state.rotation);
    let linvel = Vector::from_array(state.linvel);
    let angvel = Vector::from_array(state.angvel);
    if !owned && matches!(entry.info.role, BodyRole::Dynamic | BodyRole::Fixed) {
        if set_proxy(world, entry, target, (linvel, angvel), dt) {
            stale.push((entry.body, entry.collider));
        }
        return;
    }
    let body = &mut world.bodies[entry.body];
    match entry.info.role {
        BodyRole::Dynamic | BodyRole::Fixed => {
            body.set_position(target, true);
            body.set_linvel(linvel, true);
            body.set_angvel(angvel, true);
        }
        BodyRole::KinematicVelocityBased if owned => {
            body.set_position(target, true);
            body.set_linvel(linvel, true);
            body.set_angvel(angvel, true);
        }
        BodyRole::KinematicVelocityBased => {
            // The velocity that carries the body from where it is to the replicated pose in
            // one step; queries see it where it is now.
            let current = *body.position();
            let reach = (target.translation - current.translation) / dt;
            let turn = target.rotation * current.rotation.inverse();
            let (axis, angle) = turn.to_axis_angle();
            let angle = if angle > std::f32::consts::PI {
                angle - std::f32::consts::TAU
            } else {
                angle
            };
            body.set_linvel(reach, true);
            body.set_angvel(axis * (angle / dt), true);
            return;
        }
        BodyRole::KinematicPositionBased => {
            body.set_next_kinematic_position(target);
            return;
        }
    }
    stale.push((entry.body, entry.collider));
}

/// The speed, m/s, under which Rapier counts a body as still for sleep: a step's drift
/// (`|v| + |ω|·extent` over the step) under twice its normalised linear threshold, scaled by
/// the world's length unit (`RigidBodyActivation::update_energy`). Negative for a body that
/// never sleeps, so that any speed stirs it.
fn calm_speed(body: &RigidBody, length_unit: f32) -> f32 {
    2.0 * body.activation().normalized_linear_threshold * length_unit
}

/// How far a proxy at rest may stand from its entity's replicated pose before it is set there,
/// m (the distance plus the turn times the body's extent): ten times the noise floor's
/// perturbation, far below any error the comparison counts.
pub(crate) const REST_TOLERANCE_M: f32 = 1.0e-5;

/// How far `target` is from where `body` stands, m: the distance plus the turn times the body's
/// extent (as Rapier measures a step's drift for sleep).
fn pose_gap(body: &RigidBody, target: &Pose) -> f32 {
    let current = body.position();
    let turn = (target.rotation * current.rotation.inverse())
        .to_axis_angle()
        .1;
    let turn = turn.min(std::f32::consts::TAU - turn);
    (target.translation - current.translation).length() + turn * body.mass_properties().max_extent()
}

/// Whether a replicated state moves a proxy's body as Rapier counts motion for sleep: faster
/// than [`calm_speed`], spinning past π/2 rad/s, or further from where this world has the body
/// than a calm step moves it.
fn stirs(
    body: &RigidBody,
    target: &Pose,
    (linvel, angvel): (Vector, Vector),
    dt: f32,
    length_unit: f32,
) -> bool {
    let calm = calm_speed(body, length_unit);
    angvel.length() >= std::f32::consts::FRAC_PI_2
        || drift_speed(body, linvel, angvel) >= calm
        || pose_gap(body, target) >= calm * dt
}

/// How fast `body` moving at `linvel` and `angvel` drifts as Rapier measures it for sleep:
/// `|v| + |ω|` times its extent, m/s.
fn drift_speed(body: &RigidBody, linvel: Vector, angvel: Vector) -> f32 {
    linvel.length() + angvel.length() * body.mass_properties().max_extent()
}

/// Whether a body near `collider` (a pair in Rapier's contact graph) is asleep, or, with
/// `calm`, still enough for Rapier to be counting down to its sleep.
fn near_rest(world: &PhysicsWorld, collider: ColliderHandle, calm: bool) -> bool {
    let length_unit = world.integration_parameters.length_unit;
    world.narrow_phase.contact_pairs_with(collider).any(|pair| {
        let other = if pair.collider1 == collider {
            pair.collider2
        } else {
            pair.collider1
        };
        world
            .colliders
            .get(other)
            .and_then(|c| c.parent())
            .and_then(|b| world.bodies.get(b))
            .is_some_and(|b| {
                let still = || drift_speed(b, b.linvel(), b.angvel()) < calm_speed(b, length_unit);
                b.is_dynamic() && (b.is_sleeping() || (calm && still()))
            })
    })
}

/// Sets a proxy (Fixed, or dynamic while coupled) to a replicated state. Its velocity is set,
/// and wakes it only where the state stirs it ([`stirs`]). Its pose is set exactly, except
/// where it is within [`REST_TOLERANCE_M`] of where this world has it and setting it would
/// keep bodies awake that one world lets sleep (Rapier strongly wakes every body whose box
/// overlaps a collider moved from outside a step, however little it moved): a coupled proxy,
/// which this world simulates itself, is left where its step put it when its entity is at
/// rest or a body near it is still enough to be falling asleep, and any proxy near a body
/// asleep. Every other proxy stands exactly where its owner has it, for what game code reads.
/// docs/accuracy.md ("Sleep") has the measurements: `dominoes` struck a tick early, a stack
/// on `open/four-corners` struck awake, `crossfire`'s explosion moved 1.4 m, `grid`'s pile-up
/// solved 10 µm apart. Whether the pose was set.
fn set_proxy(
    world: &mut PhysicsWorld,
    entry: &Entry,
    target: Pose,
    motion: (Vector, Vector),
    dt: f32,
) -> bool {
    let length_unit = world.integration_parameters.length_unit;
    let body = &world.bodies[entry.body];
    let wake = stirs(body, &target, motion, dt, length_unit);
    let leave = pose_gap(body, &target) <= REST_TOLERANCE_M
        && if body.is_dynamic() {
            !wake || near_rest(world, entry.collider, true)
        } else {
            near_rest(world, entry.collider, false)
        };
    let body = &mut world.bodies[entry.body];
    body.set_linvel(motion.0, wake);
    body.set_angvel(motion.1, wake);
    if leave {
        return false;
    }
    body.set_position(target, wake);
    true
}

/// Gives a body an impulse that settles a contact this world's step has solved already: the
/// change of velocity wakes the body only where it is faster than [`calm_speed`], as Rapier's
/// own contact impulses never wake a body. Settling a resting contact across the seam every
/// step otherwise keeps both sides' bodies awake for good.
pub(crate) fn apply_settling(world: &mut PhysicsWorld, entry: &Entry, impulse: [f32; 3]) {
    let length_unit = world.integration_parameters.length_unit;
    let body = &mut world.bodies[entry.body];
    let impulse = Vector::from_array(impulse);
    let change = if body.mass() > 0.0 {
        impulse.length() / body.mass()
    } else {
        0.0
    };
    let wake = change >= calm_speed(body, length_unit);
    body.apply_impulse(impulse, wake);
}

/// Applies a (validated) write `missed` steps after the step one world would have applied it
/// before, with the motion those steps missed added: the body moved on (and turned) by the
/// change of velocity the write makes, over the missed steps. A push routed to another
/// cluster reaches its owner a tick after it was issued; without this the body ends a tick's
/// worth of the push behind one world (a ball blown 12 m/s moves 20 cm less). Only a body
/// touching nothing catches up: what one in contact would have met in the missed steps with
/// its new velocity cannot be replayed, so it is pushed late, as before.
pub(crate) fn apply_op_late(
    world: &mut PhysicsWorld,
    stale: &mut StaleBounds,
    entry: &Entry,
    op: &PhysicsOp,
    dt: f32,
    missed: u64,
) {
    let before = &world.bodies[entry.body];
    let (linvel, angvel) = (before.linvel(), before.angvel());
    apply_op(world, stale, entry, op);
    if missed == 0 || !world.bodies[entry.body].is_dynamic() {
        return;
    }
    // A body touching something would have met it with its new velocity in the missed steps;
    // moved on without those contacts it would be driven into it (piles blown apart ended
    // further from one world so): only a body in free flight catches up.
    let touching = world
        .narrow_phase
        .contact_pairs_with(entry.collider)
        .any(|pair| pair.has_any_active_contact());
    if touching {
        return;
    }
    let body = &mut world.bodies[entry.body];
    let span = dt * missed as f32;
    let (moved, turned) = match *op {
        // Its change of velocity comes in the step, by F/m·dt.
        PhysicsOp::Force { force, .. } if body.mass() > 0.0 => (
            Vector::from_array(force) * (dt / body.mass()) * span,
            Vector::ZERO,
        ),
        // Set where one world had it then; it has moved on since at its velocity.
        PhysicsOp::SetTranslation { .. } => (body.linvel() * span, Vector::ZERO),
        PhysicsOp::Wake { .. } | PhysicsOp::Sleep { .. } | PhysicsOp::Force { .. } => return,
        _ => (
            (body.linvel() - linvel) * span,
            (body.angvel() - angvel) * span,
        ),
    };
    let mut pose = *body.position();
    pose.translation += moved;
    pose.rotation = (Rotation::from_scaled_axis(turned) * pose.rotation).normalize();
    body.set_position(pose, true);
    stale.push((entry.body, entry.collider));
}

/// Applies a (validated) write.
pub(crate) fn apply_op(
    world: &mut PhysicsWorld,
    stale: &mut StaleBounds,
    entry: &Entry,
    op: &PhysicsOp,
) {
    let body = &mut world.bodies[entry.body];
    let vector = |v: [f32; 3]| Vector::from_array(v);
    match *op {
        PhysicsOp::Impulse { impulse, .. } => body.apply_impulse(vector(impulse), true),
        PhysicsOp::Force { force, .. } => body.add_force(vector(force), true),
        PhysicsOp::TorqueImpulse { torque_impulse, .. } => {
            body.apply_torque_impulse(vector(torque_impulse), true)
        }
        PhysicsOp::SetTranslation { translation, .. } => {
            body.set_translation(vector(translation), true);
            stale.push((entry.body, entry.collider));
        }
        PhysicsOp::SetLinvel { linvel, .. } => body.set_linvel(vector(linvel), true),
        PhysicsOp::SetAngvel { angvel, .. } => body.set_angvel(vector(angvel), true),
        PhysicsOp::Wake { .. } => body.wake_up(true),
        PhysicsOp::Sleep { .. } => body.sleep(),
    }
}
