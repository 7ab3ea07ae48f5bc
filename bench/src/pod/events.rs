//! Explosions and raycast volleys, run as user code inside a tick.

use std::collections::HashMap;

use seam_sim::wire::{ClusterId, EntityId, Shape};
use seam_sim::{BodyRole, PhysicsHandle, TickContext, WriteOutcome};
use serde::{Deserialize, Serialize};

use crate::scene::Event;

/// What a pod's scripted events did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct EventCounts {
    /// Projectiles fired (spawned).
    pub projectiles: u64,
    /// Explosions set off.
    pub explosions: u64,
    /// Rays cast.
    pub rays: u64,
    /// Rays that hit an entity.
    pub ray_hits: u64,
    /// Hand-offs started by this pod.
    pub handoffs: u64,
    /// Pushes applied to entities owned here.
    pub writes_local: u64,
    /// Pushes on entities another cluster owns, routed to it.
    pub writes_routed: u64,
    /// Actions refused (a write to a cluster that is not a neighbour, a spawn or hand-off the
    /// cluster refused).
    pub refused: u64,
}

/// An impulse this pod's events routed to the entity's owner: momentum in flight until the
/// owner applies it.
pub type RoutedPush = (EntityId, [f32; 3]);

/// Runs the explosions, volleys and steers of this tick (`entities`: the scene's ids by
/// name); the pushes routed to other owners are added to `routed`.
pub(super) fn run(
    actions: &[Event],
    entities: &HashMap<String, Vec<EntityId>>,
    context: &TickContext<'_>,
    physics: &mut PhysicsHandle<'_>,
    counts: &mut EventCounts,
    routed: &mut Vec<RoutedPush>,
) {
    for action in actions {
        match action {
            Event::Explosion {
                center,
                radius,
                impulse,
                ..
            } => {
                counts.explosions += 1;
                let reached = physics.intersections_with_shape(
                    &Shape::Ball { radius: *radius },
                    *center,
                    [0.0, 0.0, 0.0, 1.0],
                );
                for entity in reached {
                    // Scenery and this cluster's Fixed bodies do not move; everything else is
                    // pushed (a proxy's push goes to its owner, which knows whether its body
                    // moves).
                    let scenery = context.entity(entity).is_some_and(|info| {
                        info.owner == ClusterId::SCENERY
                            || (info.owner == context.cluster_id() && info.role == BodyRole::Fixed)
                    });
                    let Ok(position) = physics.translation(entity) else {
                        continue;
                    };
                    if scenery {
                        continue;
                    }
                    let push = explosion_push(*center, *radius, *impulse, position);
                    tally(
                        entity,
                        push,
                        physics.apply_impulse(entity, push),
                        counts,
                        routed,
                    );
                }
            }
            Event::RaycastVolley {
                origin,
                directions,
                max_distance,
                impulse,
                ..
            } => {
                for direction in directions {
                    counts.rays += 1;
                    let unit = normalized(*direction);
                    let Some(hit) = physics.raycast(*origin, unit, *max_distance, None) else {
                        continue;
                    };
                    counts.ray_hits += 1;
                    let push = unit.map(|c| c * impulse);
                    let outcome = physics.apply_impulse(hit.entity, push);
                    tally(hit.entity, push, outcome, counts, routed);
                }
            }
            Event::Steer {
                entity, velocity, ..
            } => {
                // The owner steers its own bodies; a copy owned elsewhere is steered there.
                let me = context.cluster_id();
                for &id in entities.get(entity).into_iter().flatten() {
                    if context.entity(id).is_some_and(|info| info.owner == me) {
                        tally(
                            id,
                            [0.0; 3],
                            physics.set_linvel(id, *velocity),
                            counts,
                            routed,
                        );
                    }
                }
            }
            Event::Projectile { .. } | Event::Handoff { .. } => {}
        }
    }
}

fn tally(
    entity: EntityId,
    push: [f32; 3],
    outcome: Result<WriteOutcome, seam_sim::SimError>,
    counts: &mut EventCounts,
    routed: &mut Vec<RoutedPush>,
) {
    match outcome {
        Ok(WriteOutcome::Applied) => counts.writes_local += 1,
        Ok(WriteOutcome::Routed) => {
            counts.writes_routed += 1;
            routed.push((entity, push));
        }
        Err(_) => counts.refused += 1,
    }
}

fn normalized(v: [f32; 3]) -> [f32; 3] {
    let length = v.iter().map(|c| c * c).sum::<f32>().sqrt();
    if length > 0.0 {
        v.map(|c| c / length)
    } else {
        [0.0, 1.0, 0.0]
    }
}

/// The impulse an explosion gives a body at `position`: away from the centre (up, for a body
/// at the centre), `impulse` at the centre falling linearly to zero at `radius`.
fn explosion_push(center: [f32; 3], radius: f32, impulse: f32, position: [f32; 3]) -> [f32; 3] {
    let offset = [0, 1, 2].map(|k| position[k] - center[k]);
    let distance = offset.iter().map(|c| c * c).sum::<f32>().sqrt();
    let strength = impulse * (1.0 - distance / radius).max(0.0);
    normalized(offset).map(|c| c * strength)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn explosion_push_falls_off_with_distance() {
        let near = explosion_push([0.0; 3], 4.0, 100.0, [1.0, 0.0, 0.0]);
        let far = explosion_push([0.0; 3], 4.0, 100.0, [3.0, 0.0, 0.0]);
        assert!((near[0] - 75.0).abs() < 1e-4 && (far[0] - 25.0).abs() < 1e-4);
        assert_eq!(
            explosion_push([0.0; 3], 4.0, 100.0, [0.0, 5.0, 0.0]),
            [0.0; 3]
        );
        assert_eq!(
            explosion_push([0.0; 3], 4.0, 100.0, [0.0; 3]),
            [0.0, 100.0, 0.0]
        );
    }
}
