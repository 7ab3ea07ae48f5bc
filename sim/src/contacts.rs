//! Contact events from Rapier, turned into entity pairs.

use std::sync::Mutex;

use rapier3d::prelude::*;

use crate::body::Entry;
use crate::wire::{ClusterId, EntityId, IdMap};

/// A contact between two entities that started or stopped during a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactEvent {
    /// One entity of the pair.
    pub a: EntityId,
    /// The other.
    pub b: EntityId,
    /// `true` when the contact started, `false` when it stopped.
    pub started: bool,
    /// The impulse the contact gave `b` in the step it started, N·s (`a` got its opposite);
    /// zero for a contact that stopped, or one that touched without pushing.
    pub impulse: [f32; 3],
    /// The contact normal, pointing from `a` to `b` (zero where the shapes no longer meet).
    pub normal: [f32; 3],
    /// `None`: seen in this cluster's world. `Some(c)`: reported by cluster `c`, whose world
    /// saw it (a contact with one of this cluster's entities there that this world does not
    /// model both sides of; where it models both, its own event stands for the pair).
    pub reported_by: Option<ClusterId>,
}

impl ContactEvent {
    /// A contact seen in this world, before the step's impulses are read.
    pub(crate) fn seen(a: EntityId, b: EntityId, started: bool) -> Self {
        Self {
            a,
            b,
            started,
            impulse: [0.0; 3],
            normal: [0.0; 3],
            reported_by: None,
        }
    }
}

/// Collects Rapier's collision events during a step. Rapier calls the handler through `&self`,
/// possibly from several threads, hence the lock; it is uncontended in a single-threaded step.
#[derive(Default)]
pub(crate) struct ContactCollector {
    events: Mutex<Vec<ContactEvent>>,
}

impl ContactCollector {
    /// Moves the collected events into `out` (cleared first).
    pub(crate) fn drain_into(&self, out: &mut Vec<ContactEvent>) {
        out.clear();
        if let Ok(mut events) = self.events.lock() {
            out.append(&mut events);
        }
    }
}

impl EventHandler for ContactCollector {
    fn handle_collision_event(
        &self,
        _bodies: &RigidBodySet,
        colliders: &ColliderSet,
        event: CollisionEvent,
        _contact_pair: Option<&ContactPair>,
    ) {
        let (h1, h2) = (event.collider1(), event.collider2());
        // Colliders carry their entity id as user data. A collider removed during the step
        // (its entity despawned) can no longer be named and is skipped.
        let entity = |h: ColliderHandle| colliders.get(h).map(|c| EntityId::from_u128(c.user_data));
        if let (Some(a), Some(b)) = (entity(h1), entity(h2))
            && let Ok(mut events) = self.events.lock()
        {
            events.push(ContactEvent::seen(a, b, event.started()));
        }
    }

    fn handle_contact_force_event(
        &self,
        _dt: Real,
        _bodies: &RigidBodySet,
        _colliders: &ColliderSet,
        _contact_pair: &ContactPair,
        _total_force_magnitude: Real,
    ) {
    }

    fn handle_soft_body_tear_event(&self, _soft_bodies: &SoftBodySet, _event: &SoftBodyTearEvent) {}
}

/// Fills in the impulse and normal of a contact that started in the last step, from the
/// solver's contact pair.
pub(crate) fn read_impulse(
    world: &PhysicsWorld,
    entities: &IdMap<EntityId, Entry>,
    contact: &mut ContactEvent,
) {
    let (Some(a), Some(b)) = (entities.get(&contact.a), entities.get(&contact.b)) else {
        return;
    };
    let Some(pair) = world.contact_pair(a.collider, b.collider) else {
        return;
    };
    // Rapier's impulse and normal point from its first collider to its second.
    let sign = if pair.collider1 == a.collider {
        1.0
    } else {
        -1.0
    };
    contact.impulse = (pair.total_impulse() * sign).to_array();
    if let Some(manifold) = pair.manifolds().first() {
        contact.normal = (manifold.data.normal * sign).to_array();
    }
}
