//! Which bodies touch around the seam: what a group authority policy binds into groups.
//!
//! Only groups holding a neighbour's body can need a hand-off, and a neighbour's body takes
//! part in this world's contacts only while it moves here (a coupled proxy, or a kinematic one
//! its owner moves), so the search starts from those proxies and follows active contacts
//! (contacts with points) from body to body, up to a budget of bodies per start: a pile of
//! hundreds is walked no further than a group could be given one owner. Walking every contact
//! pair of the world instead cost `grid` about 0.4 ms a cluster a tick.

use std::collections::{HashSet, VecDeque};
use std::hash::BuildHasherDefault;

use rapier3d::prelude::*;

use crate::body::Entry;
use crate::entity::BodyRole;
use crate::wire::{ClusterId, EntityId, IdHasher, IdMap, Motion};

/// Two bodies touching in a cluster's world (a contact with points), bodies that move (dynamic
/// or moved by their owner) and not scenery, with the owner each is known by there and its
/// velocity (a proxy's as its owner replicated it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touching {
    /// One body.
    pub a: EntityId,
    /// Its owner.
    pub a_owner: ClusterId,
    /// Its linear velocity, m/s.
    pub a_linvel: [f32; 3],
    /// The other.
    pub b: EntityId,
    /// Its owner.
    pub b_owner: ClusterId,
    /// Its linear velocity, m/s.
    pub b_linvel: [f32; 3],
}

/// A body reached by the walk: id, owner, velocity, collider.
type Reached = (EntityId, ClusterId, [f32; 3], ColliderHandle);

/// The touching pairs reached from this world's moving proxies (`me` is this cluster), each
/// pair once, with both owners; bodies that move only (not scenery, not Fixed bodies), at most
/// `budget` bodies walked from each proxy.
pub(crate) fn around_proxies(
    world: &PhysicsWorld,
    entities: &IdMap<EntityId, Entry>,
    me: ClusterId,
    budget: usize,
) -> Vec<Touching> {
    let reached = |id: EntityId, entry: &Entry| -> Reached {
        let linvel = if entry.info.owner == me {
            world.bodies[entry.body].linvel().to_array()
        } else {
            entry.replicated.0
        };
        (id, entry.info.owner, linvel, entry.collider)
    };
    let moving = |collider: ColliderHandle| {
        let id = EntityId::from_u128(world.colliders.get(collider)?.user_data);
        let entry = entities.get(&id)?;
        let info = &entry.info;
        (info.owner != ClusterId::SCENERY && info.body.motion != Motion::Still)
            .then(|| reached(id, entry))
    };
    let pair = |a: &Reached, b: &Reached| Touching {
        a: a.0,
        a_owner: a.1,
        a_linvel: a.2,
        b: b.0,
        b_owner: b.1,
        b_linvel: b.2,
    };
    let mut walked: HashSet<EntityId, BuildHasherDefault<IdHasher>> = HashSet::default();
    let mut pairs = Vec::new();
    let starts = entities.iter().filter(|(_, e)| {
        e.info.owner != me && e.info.owner != ClusterId::SCENERY && e.info.role != BodyRole::Fixed
    });
    for (&start, entry) in starts {
        if walked.contains(&start) {
            continue;
        }
        let mut queue = VecDeque::from([reached(start, entry)]);
        let mut left = budget.max(1);
        walked.insert(start);
        while let Some(here) = queue.pop_front() {
            if left == 0 {
                break;
            }
            left -= 1;
            for contact in world.contact_pairs_with(here.3) {
                if !contact.has_any_active_contact() {
                    continue;
                }
                let other = if contact.collider1 == here.3 {
                    contact.collider2
                } else {
                    contact.collider1
                };
                let Some(there) = moving(other) else {
                    continue;
                };
                if walked.insert(there.0) {
                    pairs.push(pair(&here, &there));
                    queue.push_back(there);
                } else if here.0 < there.0 {
                    // Both walked: a pair between them is met from each side; keep one.
                    pairs.push(pair(&here, &there));
                }
            }
        }
    }
    let key = |t: &Touching| if t.a < t.b { (t.a, t.b) } else { (t.b, t.a) };
    pairs.sort_unstable_by_key(key);
    pairs.dedup_by_key(|t| key(t));
    pairs
}
