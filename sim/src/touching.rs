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

/// The touching pairs reached from this world's moving proxies (`me` is this cluster), each
/// pair once, with both owners; bodies that move only (not scenery, not Fixed bodies), at most
/// `budget` bodies walked from each proxy.
pub(crate) fn around_proxies(
    world: &PhysicsWorld,
    entities: &IdMap<EntityId, Entry>,
    me: ClusterId,
    budget: usize,
) -> Vec<(EntityId, ClusterId, EntityId, ClusterId)> {
    let moving = |collider: ColliderHandle| {
        let id = EntityId::from_u128(world.colliders.get(collider)?.user_data);
        let entry = entities.get(&id)?;
        let info = &entry.info;
        (info.owner != ClusterId::SCENERY && info.body.motion != Motion::Still).then_some((
            id,
            info.owner,
            entry.collider,
        ))
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
        let mut queue = VecDeque::from([(start, entry.info.owner, entry.collider)]);
        let mut left = budget.max(1);
        walked.insert(start);
        while let Some((id, owner, collider)) = queue.pop_front() {
            if left == 0 {
                break;
            }
            left -= 1;
            for pair in world.contact_pairs_with(collider) {
                if !pair.has_any_active_contact() {
                    continue;
                }
                let other = if pair.collider1 == collider {
                    pair.collider2
                } else {
                    pair.collider1
                };
                let Some((other_id, other_owner, other_collider)) = moving(other) else {
                    continue;
                };
                if walked.insert(other_id) {
                    queue.push_back((other_id, other_owner, other_collider));
                    pairs.push((id, owner, other_id, other_owner));
                } else if id < other_id {
                    // Both walked: a pair between them is met from each side; keep one.
                    pairs.push((id, owner, other_id, other_owner));
                }
            }
        }
    }
    pairs.sort_unstable_by_key(|&(a, _, b, _)| if a < b { (a, b) } else { (b, a) });
    pairs.dedup_by_key(|&mut (a, _, b, _)| if a < b { (a, b) } else { (b, a) });
    pairs
}
