//! Whether every entity of a run ended with exactly one owner.

use std::collections::{HashMap, HashSet};

use seam_sim::wire::{ClusterId, EntityId};
use serde::Serialize;

use crate::node::NodeReport;
use crate::pod::SceneIds;
use crate::scene::Scene;

/// How many of a run's entities ended owned once, not at all, or more than once.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Ownership {
    /// Entities that must have an owner at the end: every entity the scene spawns, every
    /// projectile a final pod saw in its world (looked for every few ticks), and whatever a pod
    /// owns.
    pub expected: usize,
    /// Of those, owned by exactly one pod.
    pub owned_once: usize,
    /// Owned by no pod: lost.
    pub lost: Vec<EntityId>,
    /// Owned by more than one pod.
    pub duplicated: Vec<EntityId>,
    /// The scene names of the lost and the doubled (`name#i` for a grid copy, `projectile of
    /// event i, shot k`), to tell at a glance what went wrong.
    pub names: Vec<String>,
}

impl Ownership {
    /// Whether every expected entity has exactly one owner.
    pub fn holds(&self) -> bool {
        self.lost.is_empty() && self.duplicated.is_empty()
    }
}

/// The id of every owned entity `scene` spawns (scenery is nobody's), as pods of run `run_id`
/// name them.
pub fn scene_entity_ids(scene: &Scene, run_id: &str) -> Vec<EntityId> {
    let ids = SceneIds::new(run_id, &scene.name);
    scene
        .entities
        .iter()
        .filter(|entity| !entity.is_scenery())
        .flat_map(|entity| {
            let count = entity
                .grid
                .map_or(1, |g| g.count.iter().product::<u32>() as u64);
            (0..count).map(|index| ids.entity(&entity.name, index))
        })
        .collect()
}

/// Checks the final reports of a run's pods (one per cluster: the last incarnation of a pod
/// that was restarted).
pub fn check(scene: &Scene, run_id: &str, reports: &[NodeReport]) -> Ownership {
    let mut owners: HashMap<EntityId, usize> = HashMap::new();
    for report in reports {
        for &id in &report.owned {
            *owners.entry(id).or_default() += 1;
        }
    }
    let mut expected: HashSet<EntityId> = scene_entity_ids(scene, run_id).into_iter().collect();
    for report in reports {
        expected.extend(report.projectiles_seen.iter().copied());
    }
    expected.extend(owners.keys().copied());
    let mut lost: Vec<EntityId> = expected
        .iter()
        .filter(|id| !owners.contains_key(id))
        .copied()
        .collect();
    let mut duplicated: Vec<EntityId> = owners
        .iter()
        .filter(|&(_, &n)| n > 1)
        .map(|(&id, _)| id)
        .collect();
    lost.sort();
    duplicated.sort();
    let cluster_name = |id: ClusterId| {
        reports
            .iter()
            .find(|r| r.cluster_id == id.to_string())
            .map_or_else(|| id.to_string(), |r| r.cluster.clone())
    };
    let seen_as = |id: EntityId| {
        let seen: Vec<String> = reports
            .iter()
            .flat_map(|r| {
                r.proxied
                    .iter()
                    .filter(move |(e, _)| *e == id)
                    .map(|&(_, owner)| format!("{}'s at {}", cluster_name(owner), r.cluster))
            })
            .collect();
        if seen.is_empty() {
            " (in no world)".to_owned()
        } else {
            format!(" (a proxy of {})", seen.join(", "))
        }
    };
    let names = lost
        .iter()
        .map(|&id| format!("lost {}{}", name_of(scene, run_id, id), seen_as(id)))
        .chain(
            duplicated
                .iter()
                .map(|&id| format!("owned twice {}", name_of(scene, run_id, id))),
        )
        .collect();
    Ownership {
        expected: expected.len(),
        owned_once: owners.values().filter(|&&n| n == 1).count(),
        lost,
        duplicated,
        names,
    }
}

/// The scene name of entity `id` of run `run_id`: `name`, `name#i` for a grid copy,
/// `projectile of event i, shot k`, or the id itself.
pub fn name_of(scene: &Scene, run_id: &str, id: EntityId) -> String {
    let ids = SceneIds::new(run_id, &scene.name);
    for entity in &scene.entities {
        let copies = entity.copies();
        for index in 0..copies {
            if ids.entity(&entity.name, index) == id {
                return if copies > 1 {
                    format!("{}#{index}", entity.name)
                } else {
                    entity.name.clone()
                };
            }
        }
    }
    for (index, event) in scene.events.iter().enumerate() {
        let shots = match event.every() {
            Some(every) if every > 0 => scene.ticks.saturating_sub(event.tick()) / every + 1,
            _ => 1,
        };
        if let Some(shot) = (0..shots).find(|&shot| ids.event_entity(index, shot) == id) {
            return format!("projectile of event {index}, shot {shot}");
        }
    }
    id.to_string()
}
