//! Authority flips as a free-running pod sees them: the last state of each body it stopped
//! owning and the first state of each it started owning, so a hand-off's jump can be judged
//! against a single-world run afterwards (`accuracy::free`).

use serde::{Deserialize, Serialize};

use seam_sim::BodyRole;
use seam_sim::wire::{EntityId, IdMap};

/// One side of a flip.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FlipRecord {
    /// The body.
    pub entity: EntityId,
    /// The tick of the state (after that tick's step).
    pub tick: u64,
    /// Where it was.
    pub position: [f32; 3],
    /// Its linear velocity.
    pub linvel: [f32; 3],
    /// True: the first state this pod owned; false: the last one before it stopped owning it.
    pub took: bool,
}

/// Follows which dynamic bodies a pod owns, tick by tick.
#[derive(Debug, Default)]
pub(super) struct FlipLog {
    owned: IdMap<EntityId, FlipRecord>,
    pub(super) records: Vec<FlipRecord>,
    started: bool,
}

impl FlipLog {
    /// Notes the dynamic bodies `sim` owns after `tick`; owned by `me`.
    pub(super) fn observe(&mut self, sim: &seam_sim::ClusterSim, me: seam_sim::wire::ClusterId) {
        let tick = sim.tick();
        let mut now: IdMap<EntityId, FlipRecord> = IdMap::default();
        for (id, info) in sim.entities() {
            if info.owner != me || info.role != BodyRole::Dynamic {
                continue;
            }
            let Some(state) = sim.state(id) else { continue };
            let record = FlipRecord {
                entity: id,
                tick,
                position: state.position,
                linvel: state.linvel,
                took: true,
            };
            if self.started && !self.owned.contains_key(&id) {
                self.records.push(record);
            }
            now.insert(id, record);
        }
        for (id, last) in &self.owned {
            if !now.contains_key(id) {
                self.records.push(FlipRecord {
                    took: false,
                    ..*last
                });
            }
        }
        self.owned = now;
        self.started = true;
    }
}
