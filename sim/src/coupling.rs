//! Contacts across the seam: proxies that meet this cluster's bodies with the entity's own mass.
//!
//! Between contacts a proxy is what its mode makes it: a Fixed body standing at the replicated
//! pose, or a kinematic one moving along its dead-reckoned path. To a body this cluster
//! simulates, either is infinitely heavy: a ball stops dead on it, and a kinematic proxy of a
//! 1 kg ball shoves a 20 kg crate as if it weighed nothing less than a wall.
//!
//! > Before each step, every proxy of a **simulated** entity (dynamic at its owner) that a body
//! > this cluster simulates may touch during the step — directly, or through other such
//! > proxies — becomes a **dynamic body of the entity's own mass**, moving with the replicated
//! > velocity. Once nothing of this cluster's can reach it, it goes back to its mode's role,
//! > where it is.
//!
//! The owner's world does the same with its proxy of this cluster's body, so each world solves
//! the contact from the same two bodies and keeps its own body's share: the ball bounces off a
//! crate of the crate's mass here, the crate takes the ball's momentum there. Nothing is
//! routed, so the push lands in the step the bodies meet, not a frame later. A coupled proxy
//! is simulated between replication frames and set to each frame's state when it comes; a
//! proxy of an entity its owner moves itself (a Fixed floor, a kinematic door) is never coupled:
//! it is as immovable here as it is there.
//!
//! A Fixed proxy stands where its owner's last frame put it, while the entity moves on until
//! the next frame. So it is judged, and coupled, where its replicated velocity has carried it
//! since (at most [`MAX_LEAD_TICKS`]): with a frame every 8 ticks, a ball rolled at a crate
//! would otherwise meet the crate's proxy where the crate was up to 8 ticks before.
//!
//! "May touch" is judged on boxes: the proxy's box swept by its replicated velocity over a step,
//! against each simulated body's box swept by its velocity, both grown by [`REACH_MARGIN_M`].

use rapier3d::prelude::*;

use crate::body::Entry;
use crate::box_grid::BoxGrid;
use crate::entity::BodyRole;
use crate::wire::{ClusterId, EntityId, EntityState, IdMap, Motion};

/// How much closer than touching two swept boxes must come for a proxy to be coupled, metres:
/// room for Rapier's contact prediction and for a step's worth of gravity.
pub const REACH_MARGIN_M: f32 = 0.05;

/// What one coupling pass changed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CouplingChanges {
    /// Proxies made dynamic for this step.
    pub coupled: u32,
    /// Proxies given back their mode's role.
    pub released: u32,
    /// Proxies dynamic for this step, newly or still.
    pub dynamic: u32,
}

/// The box a body's collider covers at the body's pose now (a body moved since the last step
/// has a collider that does not know it yet), swept by `velocity` over `dt` and grown by
/// `margin`.
/// The most ticks a Fixed proxy is carried forward by its replicated velocity when coupled:
/// past a few frames' worth, the owner's frames have stopped coming and a guess is no better.
pub const MAX_LEAD_TICKS: u64 = 16;

/// Cell side of the grid the proxies' boxes are filed in when coupling spreads through them, m:
/// about a body's size, so a box touches a few cells.
const PROXY_GRID_CELL_M: f32 = 2.0;

fn swept_box(
    body: &RigidBody,
    collider: &Collider,
    velocity: Vector,
    dt: f32,
    margin: f32,
) -> Aabb {
    let now = collider.shape().compute_aabb(body.position());
    let moved = Aabb::new(now.mins + velocity * dt, now.maxs + velocity * dt);
    now.merged(&moved).loosened(margin)
}

/// How far a proxy is led from where it stands: a Fixed proxy stands where its owner's last
/// frame put it; with a frame every few ticks the entity has moved on since. It is judged, and
/// coupled, where its replicated velocity has carried it (a kinematic proxy is carried by its
/// own dead reckoning).
fn lead(e: &Entry, now: u64, dt: f32) -> Vector {
    if e.info.role != BodyRole::Fixed {
        return Vector::ZERO;
    }
    Vector::from_array(e.replicated.0) * (ticks_behind(now, e.posed_tick) as f32 * dt)
}

/// How many ticks a state of tick `state_tick` is behind a world at tick `now` (negative: ahead),
/// as far as it can be carried: a state one tick ahead is a staggered neighbour's of the step
/// this world is about to take, and one is carried forward at most [`MAX_LEAD_TICKS`]. A state
/// further off than either is from a pod that counts its ticks from another start (game
/// servers need not share a tick count), and is taken as of `now`: 0.
pub(crate) fn ticks_behind(now: u64, state_tick: u64) -> i64 {
    let behind = now as i64 - state_tick as i64;
    if (-1..=MAX_LEAD_TICKS as i64).contains(&behind) {
        behind
    } else if behind > MAX_LEAD_TICKS as i64 && behind <= 4 * MAX_LEAD_TICKS as i64 {
        MAX_LEAD_TICKS as i64
    } else {
        0
    }
}

/// `state`, `behind` ticks (of `dt`) old, carried to now along its replicated velocities
/// (back, for a state ahead).
pub(crate) fn carried(state: &EntityState, behind: i64, dt: f32) -> EntityState {
    if behind == 0 {
        return *state;
    }
    let shift = behind as f32 * dt;
    let [x, y, z, w] = state.rotation;
    let turn = Rotation::from_scaled_axis(Vector::from_array(state.angvel) * shift);
    EntityState {
        position: std::array::from_fn(|k| state.position[k] + state.linvel[k] * shift),
        rotation: (turn * Rotation::from_xyzw(x, y, z, w))
            .normalize()
            .to_array(),
        ..*state
    }
}

/// Makes the proxies that bodies simulated here may touch this step dynamic, and the others
/// `rest` (their mode's role), as the module says. `me` is this cluster.
pub(crate) fn couple(
    world: &mut PhysicsWorld,
    entities: &mut IdMap<EntityId, Entry>,
    me: ClusterId,
    rest: BodyRole,
    now: u64,
    dt: f32,
) -> CouplingChanges {
    let proxies = reaches(world, entities, me, now, dt);
    let dynamic = touched(world, entities, me, &proxies, dt);
    set_roles(world, entities, &proxies, &dynamic, rest, now, dt)
}

/// The proxies of simulated entities, by their index in `entities`, with the box each may
/// sweep this step (led to where its replicated velocity has carried it).
fn reaches(
    world: &PhysicsWorld,
    entities: &IdMap<EntityId, Entry>,
    me: ClusterId,
    now: u64,
    dt: f32,
) -> Vec<(usize, Aabb)> {
    let is_proxy = |e: &Entry| {
        e.info.owner != me
            && e.info.owner != ClusterId::SCENERY
            && e.info.body.motion == Motion::Simulated
    };
    let mut proxies: Vec<(usize, Aabb)> = Vec::new();
    for (index, (_, entry)) in entities.iter().enumerate() {
        if !is_proxy(entry) {
            continue;
        }
        let velocity = Vector::from_array(entry.replicated.0);
        let (body, collider) = (&world.bodies[entry.body], &world.colliders[entry.collider]);
        let swept = swept_box(body, collider, velocity, dt, REACH_MARGIN_M);
        let lead = lead(entry, now, dt);
        proxies.push((index, Aabb::new(swept.mins + lead, swept.maxs + lead)));
    }
    proxies
}

/// Which of `proxies` a body simulated here may touch this step, directly or through other
/// proxies it may touch.
fn touched(
    world: &PhysicsWorld,
    entities: &IdMap<EntityId, Entry>,
    me: ClusterId,
    proxies: &[(usize, Aabb)],
    dt: f32,
) -> Vec<bool> {
    let mut dynamic = vec![false; proxies.len()];
    // The fastest body simulated here bounds how far a query must look around a proxy.
    let mut fastest = 0.0f32;
    let mut any_simulated = false;
    for entry in entities.values() {
        if entry.info.owner == me && entry.info.role == BodyRole::Dynamic {
            any_simulated = true;
            fastest = fastest.max(world.bodies[entry.body].linvel().length());
        }
    }
    if !any_simulated || proxies.is_empty() {
        return dynamic;
    }
    // The query structure is left as the last step made it (refreshing it here would change
    // how the next step pairs bodies, and so its result): its boxes are where bodies were at
    // the start of that step, so the search looks a step further.
    let simulated_here = |collider: &Collider| {
        entities
            .get(&EntityId::from_u128(collider.user_data))
            .is_some_and(|e| e.info.owner == me && e.info.role == BodyRole::Dynamic)
    };
    let mut queue = Vec::new();
    for (slot, (_, reach)) in proxies.iter().enumerate() {
        let look = reach.loosened(2.0 * fastest * dt);
        let touched = world
            .intersect_aabb_conservative(look, QueryFilter::only_dynamic())
            .any(|(_, collider)| {
                let Some(body) = collider.parent().and_then(|p| world.bodies.get(p)) else {
                    return false;
                };
                simulated_here(collider)
                    && swept_box(body, collider, body.linvel(), dt, 0.0).intersects(reach)
            });
        if touched {
            dynamic[slot] = true;
            queue.push(slot);
        }
    }
    through_proxies(proxies, &mut dynamic, queue);
    dynamic
}

/// What a coupled proxy may touch is coupled too, so a push passes down a row of the
/// neighbour's bodies as it would in one world. Proxies moved since the last step are not
/// where the query structure has them, so this goes through the proxies' own boxes, filed in a
/// grid so that each coupled proxy looks only at those near it (the same closure as testing
/// every pair).
fn through_proxies(proxies: &[(usize, Aabb)], dynamic: &mut [bool], mut queue: Vec<usize>) {
    if queue.is_empty() {
        return;
    }
    let mut grid = BoxGrid::new(PROXY_GRID_CELL_M);
    for (slot, (_, reach)) in proxies.iter().enumerate() {
        grid.insert(slot as u32, reach.mins.to_array(), reach.maxs.to_array());
    }
    grid.seal();
    while let Some(from) = queue.pop() {
        let reach = proxies[from].1;
        grid.any(reach.mins.to_array(), reach.maxs.to_array(), |other| {
            let other = other as usize;
            if !dynamic[other] && proxies[other].1.intersects(&reach) {
                dynamic[other] = true;
                queue.push(other);
            }
            false
        });
    }
}

/// Gives each proxy its role for the step: dynamic where `dynamic` says, else `rest`.
fn set_roles(
    world: &mut PhysicsWorld,
    entities: &mut IdMap<EntityId, Entry>,
    proxies: &[(usize, Aabb)],
    dynamic: &[bool],
    rest: BodyRole,
    now: u64,
    dt: f32,
) -> CouplingChanges {
    let mut changes = CouplingChanges::default();
    for (slot, &(index, _)) in proxies.iter().enumerate() {
        let (_, entry) = entities
            .get_index_mut(index)
            .expect("proxy indices come from this map");
        let want = if dynamic[slot] {
            BodyRole::Dynamic
        } else {
            rest
        };
        if dynamic[slot] {
            changes.dynamic += 1;
        }
        if entry.info.role == want {
            continue;
        }
        let lead = lead(entry, now, dt);
        let body = &mut world.bodies[entry.body];
        if want == BodyRole::Dynamic && lead != Vector::ZERO {
            let at = body.translation() + lead;
            body.set_translation(at, true);
        }
        body.set_body_type(want.rapier(), true);
        if want == BodyRole::Dynamic {
            // It meets this cluster's bodies with the motion its owner gave it, not the
            // standing still of a Fixed body or the catching up of a dead-reckoned one.
            body.set_linvel(Vector::from_array(entry.replicated.0), true);
            body.set_angvel(Vector::from_array(entry.replicated.1), true);
            changes.coupled += 1;
        } else {
            // Left where the steps put it, which is where the entity is now.
            entry.posed_tick = now;
            changes.released += 1;
        }
        entry.info.role = want;
    }
    changes
}

/// What a contact between a body simulated here and a coupled proxy did to the body in the
/// last step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeamImpulse {
    /// The body simulated here.
    pub own: EntityId,
    /// The proxy (of an entity owned elsewhere).
    pub proxy: EntityId,
    /// The impulse the contact gave `own`, N·s.
    pub impulse: [f32; 3],
}

/// The impulses of the last step between bodies simulated here and coupled proxies, one per
/// touching pair.
pub(crate) fn seam_impulses(
    world: &PhysicsWorld,
    entities: &IdMap<EntityId, Entry>,
    me: ClusterId,
) -> Vec<SeamImpulse> {
    let mut out = Vec::new();
    for (&proxy, entry) in entities {
        if entry.info.owner == me || entry.info.role != BodyRole::Dynamic {
            continue;
        }
        for pair in world.contact_pairs_with(entry.collider) {
            if !pair.has_any_active_contact() {
                continue;
            }
            let (other, sign) = if pair.collider1 == entry.collider {
                // Rapier's impulse pushes its second collider: here, the other body.
                (pair.collider2, 1.0)
            } else {
                (pair.collider1, -1.0)
            };
            let Some(collider) = world.colliders.get(other) else {
                continue;
            };
            let own = EntityId::from_u128(collider.user_data);
            let simulated_here = entities
                .get(&own)
                .is_some_and(|e| e.info.owner == me && e.info.role == BodyRole::Dynamic);
            if simulated_here {
                out.push(SeamImpulse {
                    own,
                    proxy,
                    impulse: (pair.total_impulse() * sign).to_array(),
                });
            }
        }
    }
    out
}
