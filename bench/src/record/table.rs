//! The header of a run's recording, and the entity and cluster numbering every pod of the run
//! derives from its scene alone.

use std::collections::HashMap;

use seam_sim::wire::{ClusterId, EntityId, IdMap};

use super::{EntityGroup, Header, RecordedCluster, ScenePose, heading};
use crate::pod::SceneIds;
use crate::scene::{Event, Role, Scene, SceneShape};

/// A run's header with the lookups a recorder needs.
#[derive(Debug, Clone)]
pub struct EntityTable {
    /// The header.
    pub header: Header,
    /// Entity id → index.
    pub entities: IdMap<EntityId, u32>,
    /// Cluster id → stream (the reference world's included when recorded).
    pub streams: HashMap<ClusterId, u16>,
    /// Per entity index: whether its heading shows from above (a box; a ball or an upright
    /// capsule looks the same whichever way it turns, and is written with heading 0).
    pub turns: Vec<bool>,
}

impl EntityTable {
    /// The table of run `run_id` of `scene` (already stacked) over `ticks` ticks; `reference`
    /// adds the single world's stream.
    pub fn new(
        scene: &Scene,
        run_id: &str,
        ticks: u64,
        rate_hz: f64,
        source: &str,
        reference: bool,
    ) -> Self {
        let ids = SceneIds::new(run_id, &scene.name);
        let mut entities = IdMap::default();
        let mut groups = Vec::new();
        let mut scenery = Vec::new();
        let mut next = 0u32;
        for entity in &scene.entities {
            let grid = entity.grid.unwrap_or(crate::scene::Grid {
                count: [1, 1, 1],
                spacing: [0.0; 3],
            });
            let first = next;
            for i in 0..grid.count[0] {
                for j in 0..grid.count[1] {
                    for k in 0..grid.count[2] {
                        let copy = u64::from(next - first);
                        entities.insert(ids.entity(&entity.name, copy), next);
                        if entity.role == Role::Scenery {
                            let offset = [i, j, k].map(|n| n as f32);
                            scenery.push(ScenePose {
                                entity: next,
                                position: [0, 1, 2]
                                    .map(|a| entity.position[a] + offset[a] * grid.spacing[a]),
                                heading: heading(entity.rotation),
                            });
                        }
                        next += 1;
                    }
                }
            }
            groups.push(EntityGroup {
                name: entity.name.clone(),
                first,
                copies: next - first,
                shape: entity.shape.clone(),
                role: role_name(entity.role).into(),
            });
        }
        number_projectiles(scene, &ids, ticks, &mut next, &mut entities, &mut groups);
        let mut streams: HashMap<ClusterId, u16> = scene
            .clusters
            .iter()
            .enumerate()
            .map(|(i, c)| (ids.cluster(&c.name), i as u16))
            .collect();
        let mut names: Vec<String> = scene.clusters.iter().map(|c| c.name.clone()).collect();
        if reference {
            streams.insert(
                ids.cluster(crate::pod::REFERENCE_CLUSTER),
                names.len() as u16,
            );
            names.push("reference".into());
        }
        let mut turns = vec![false; next as usize];
        for group in &groups {
            if matches!(group.shape, SceneShape::Cuboid { .. }) {
                turns[group.first as usize..(group.first + group.copies) as usize].fill(true);
            }
        }
        let header = Header {
            scene: scene.name.clone(),
            source: source.into(),
            run_id: run_id.into(),
            dt: scene.dt,
            ticks,
            rate_hz,
            clusters: recorded_clusters(scene),
            streams: names,
            groups,
            scenery,
            entities: next,
        };
        Self {
            header,
            entities,
            streams,
            turns,
        }
    }
}

fn role_name(role: Role) -> &'static str {
    match role {
        Role::Dynamic => "dynamic",
        Role::Fixed => "fixed",
        Role::Kinematic => "kinematic",
        Role::Scenery => "scenery",
    }
}

/// Numbers every projectile a scene's events fire within `ticks` ticks from `next` on, a
/// group per event.
fn number_projectiles(
    scene: &Scene,
    ids: &SceneIds,
    ticks: u64,
    next: &mut u32,
    entities: &mut IdMap<EntityId, u32>,
    groups: &mut Vec<EntityGroup>,
) {
    for (index, event) in scene.events.iter().enumerate() {
        let Event::Projectile { radius, .. } = event else {
            continue;
        };
        let first = *next;
        for tick in event.tick()..ticks.max(event.tick() + 1) {
            if let Some(shot) = event.shot_at(tick) {
                entities.insert(ids.event_entity(index, shot), *next);
                *next += 1;
            }
        }
        groups.push(EntityGroup {
            name: format!("projectile {index}"),
            first,
            copies: *next - first,
            shape: SceneShape::Ball { radius: *radius },
            role: "projectile".into(),
        });
    }
}

/// The scene's clusters as a recording names them.
fn recorded_clusters(scene: &Scene) -> Vec<RecordedCluster> {
    scene
        .clusters
        .iter()
        .map(|c| RecordedCluster {
            name: c.name.clone(),
            min: c.region.min,
            max: c.region.max,
            spread: c.spread,
            host: c.host.clone(),
        })
        .collect()
}
