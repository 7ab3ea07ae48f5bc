//! Ids every pod of a run derives the same way, with no coordination.
//!
//! Cluster and entity ids are 128-bit FNV-1a hashes of the run id, the scene's name and the
//! thing's name, so pods started separately (on one host or several) agree on every id, and two
//! runs of one scene with different run ids share no channel.

use seam_sim::wire::{ClusterId, EntityId};

const OFFSET: u128 = 0x6c62272e07bb014262b821756295c58d;
const PRIME: u128 = 0x0000000001000000000000000000013b;

fn fnv1a(parts: &[&[u8]]) -> u128 {
    let mut hash = OFFSET;
    for part in parts {
        for &byte in *part {
            hash ^= u128::from(byte);
            hash = hash.wrapping_mul(PRIME);
        }
        // A separator, so ("ab", "c") and ("a", "bc") differ.
        hash ^= 0xff;
        hash = hash.wrapping_mul(PRIME);
    }
    hash
}

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

    fn hash(&self, kind: &str, name: &str, index: u64) -> u128 {
        fnv1a(&[
            self.run_id.as_bytes(),
            self.scene.as_bytes(),
            kind.as_bytes(),
            name.as_bytes(),
            &index.to_le_bytes(),
        ])
    }

    /// The cluster named `name` in the scene.
    pub fn cluster(&self, name: &str) -> ClusterId {
        ClusterId::from_u128(self.hash("cluster", name, 0))
    }

    /// Copy `index` of the scene entity named `name` (0 for an entity without a grid).
    pub fn entity(&self, name: &str, index: u64) -> EntityId {
        EntityId::from_u128(self.hash("entity", name, index))
    }

    /// The entity made by repetition `shot` of the scene's event number `index` (a
    /// projectile).
    pub fn event_entity(&self, index: usize, shot: u64) -> EntityId {
        EntityId::from_u128(self.hash("event", &index.to_string(), shot))
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
