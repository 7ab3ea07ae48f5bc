//! Ids every pod of a run derives the same way, with no coordination.
//!
//! Cluster and entity ids are the library's named ids (`ClusterId::named`,
//! `EntityId::named`: hashes of the run id and a name) of the scene's name and the thing's
//! name, so pods started separately (on one host or several) agree on every id, and two runs
//! of one scene with different run ids share no channel.

use seam_sim::wire::{ClusterId, EntityId};

/// Derives the ids of one run of one scene.
#[derive(Debug, Clone)]
pub struct SceneIds {
    run_id: String,
    scene: String,
}

impl SceneIds {
    /// Ids for run `run_id` of the scene named `scene`.
    pub fn new(run_id: &str, scene: &str) -> Self {
        Self {
            run_id: run_id.to_owned(),
            scene: scene.to_owned(),
        }
    }

    /// The cluster named `name` in the scene.
    pub fn cluster(&self, name: &str) -> ClusterId {
        ClusterId::named(&self.run_id, &format!("{}/{name}", self.scene))
    }

    /// Copy `index` of the scene entity named `name` (0 for an entity without a grid).
    pub fn entity(&self, name: &str, index: u64) -> EntityId {
        EntityId::named(&self.run_id, &format!("{}/{name}#{index}", self.scene))
    }

    /// The entity made by repetition `shot` of the scene's event number `index` (a
    /// projectile).
    pub fn event_entity(&self, index: usize, shot: u64) -> EntityId {
        EntityId::named(
            &self.run_id,
            &format!("{}/event {index}, shot {shot}", self.scene),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_stable_and_distinct() {
        let ids = SceneIds::new("run", "crossfire");
        assert_eq!(
            ids.cluster("west"),
            SceneIds::new("run", "crossfire").cluster("west")
        );
        assert_ne!(ids.cluster("west"), ids.cluster("east"));
        assert_ne!(
            ids.cluster("west"),
            SceneIds::new("other", "crossfire").cluster("west")
        );
        assert_ne!(ids.entity("crate", 0), ids.entity("crate", 1));
        assert_ne!(ids.entity("ab", 0).as_u128(), ids.cluster("ab").as_u128());
        assert_ne!(ids.event_entity(0, 0), ids.event_entity(1, 0));
        assert_ne!(ids.event_entity(0, 1), ids.event_entity(1, 0));
    }
}
