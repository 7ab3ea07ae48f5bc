//! [`Custody`]: the entities of neighbours taken for dead — adopted from each one's last
//! picture by the rule of `crate::authority::adoption`, and handed back when it returns.

use seam_sim::ClusterSim;
use seam_sim::wire::{ClusterId, EntityId, EntityState, IdMap};

use super::liveness::Neighbours;
use crate::authority::adoption;
use crate::config::ClusterConfig;
use crate::events::{ClusterEvent, Events};
use crate::handoff::{Handoffs, owner_role, take_back};
use crate::inbox::HeldReplication;

/// Each neighbour's last picture, and the entities this cluster holds for neighbours taken
/// for dead.
#[derive(Debug, Default)]
pub(crate) struct Custody {
    /// The states of each neighbour's last replication frame (kept only with a world map):
    /// what its entities are adopted from if it dies.
    last: IdMap<ClusterId, HeldReplication>,
    /// Entities this cluster adopted (or took back from a neighbour that died before taking
    /// them), with the cluster they came from: if it returns and still claims one, it gets it
    /// back.
    adopted: IdMap<EntityId, ClusterId>,
}

impl Custody {
    /// Keeps `frame` as its sender's last picture. A delta frame without its keyframe is
    /// filled from the picture held before.
    pub(crate) fn keep_last(&mut self, mut frame: HeldReplication) {
        if !frame.is_whole()
            && let Some(older) = self.last.get(&frame.from)
        {
            frame.fill_from(older);
        }
        self.last.insert(frame.from, frame);
    }

    /// Whether no entity is held for another cluster.
    pub(crate) fn is_empty(&self) -> bool {
        self.adopted.is_empty()
    }

    /// The cluster `entity` is held for, if this cluster holds it as an adopter.
    pub(crate) fn adopted_from(&self, entity: EntityId) -> Option<ClusterId> {
        if self.adopted.is_empty() {
            return None;
        }
        self.adopted.get(&entity).copied()
    }

    /// Entities this cluster owned and yielded to a later claim: an adopted one among them is
    /// that claimant's now, with nothing to return (counted).
    pub(crate) fn yielded(&mut self, entities: &[EntityId], events: &mut Events) {
        for &entity in entities {
            if let Some(from) = self.adopted.swap_remove(&entity) {
                events.emit(ClusterEvent::AdoptionYielded { entity, from });
            }
        }
    }

    /// `entity` is handed on: this cluster no longer holds it for anyone.
    pub(crate) fn release(&mut self, entity: EntityId) {
        self.adopted.swap_remove(&entity);
    }

    /// The entities of `dead`, taken for dead just now: those the adoption rule gives this
    /// cluster become its own, from their last replicated state; those handed to `dead` that
    /// it never took come back; every other proxy of `dead` is despawned (its adopter's frames
    /// bring it back).
    pub(crate) fn adopt_from(
        &mut self,
        dead: ClusterId,
        sim: &mut ClusterSim,
        config: &ClusterConfig,
        neighbours: &Neighbours,
        handoffs: &mut Handoffs,
        events: &mut Events,
    ) {
        let me = config.cluster_id;
        let last: Vec<EntityState> = self
            .last
            .swap_remove(&dead)
            .map(|frame| frame.states().filter_map(Result::ok).collect())
            .unwrap_or_default();
        let alive = |c: ClusterId| c == me || !neighbours.is_gone(c);
        for state in last.iter().filter(|s| s.cluster_id == dead) {
            if adoption::adopter(&config.world, dead, state.position, alive) != Some(me) {
                continue;
            }
            // At the next epoch: the adopter's claim (and its return, at the one after)
            // outranks anything the dead cluster says of the entity at its own epoch, if it was
            // only stalled and hands the entity on as it catches up.
            let known = sim.info(state.id).map(|i| (i.owner, i.epoch));
            let adopted = EntityState {
                cluster_id: me,
                epoch: state.epoch.max(known.map_or(0, |(_, e)| e)) + 1,
                ..*state
            };
            let done = match known.map(|(owner, _)| owner) {
                Some(owner) if owner == dead => sim
                    .set_role(state.id, owner_role(state))
                    .and_then(|()| sim.apply_state(&adopted)),
                None => sim.spawn(&adopted, owner_role(state)),
                // Already someone else's here: not the dead cluster's to give.
                Some(_) => continue,
            };
            if done.is_ok() {
                self.adopted.insert(state.id, dead);
                events.emit(ClusterEvent::EntityAdopted {
                    entity: state.id,
                    from: dead,
                });
            }
        }
        // What is left of `dead` here: entities this cluster handed to it that it never listed
        // (taken back: this cluster had them last), and proxies of entities another survivor
        // adopts.
        let left: Vec<EntityId> = sim
            .entities()
            .filter(|(_, info)| info.owner == dead)
            .map(|(id, _)| id)
            .collect();
        for id in left {
            // Never taken: its last frame does not list it as its own (it may list it as a
            // hand-off to this cluster, if this was a hand-back it never took).
            let never_taken = handoffs
                .take_in_transit(id)
                .filter(|_| !last.iter().any(|s| s.id == id && s.cluster_id == dead));
            if never_taken.is_some_and(|handed| take_back(sim, me, &handed)) {
                self.adopted.insert(id, dead);
                events.emit(ClusterEvent::HandoffReclaimed {
                    entity: id,
                    from: dead,
                });
            } else if sim.despawn(id).is_ok() {
                events.emit(ClusterEvent::ProxyDespawned { entity: id });
            }
        }
        handoffs.forget_in_transit_to(dead);
    }

    /// Hands every entity adopted from `neighbour`, which is back, to it again at the next
    /// replication frame: a restarted pod starts empty and gets its entities back; a stalled
    /// one that still simulates them keeps its own copy (a hand-off of an entity it owns
    /// changes nothing there), and this cluster's copy stops.
    pub(crate) fn return_to(
        &mut self,
        neighbour: ClusterId,
        sim: &ClusterSim,
        handoffs: &mut Handoffs,
        events: &mut Events,
    ) {
        let me = sim.config().cluster_id;
        let back: Vec<EntityId> = self
            .adopted
            .iter()
            .filter(|&(id, &from)| {
                from == neighbour && sim.info(*id).is_some_and(|i| i.owner == me)
            })
            .map(|(&id, _)| id)
            .collect();
        for id in back {
            self.adopted.swap_remove(&id);
            handoffs.queue(id, neighbour);
            events.emit(ClusterEvent::EntityReturned {
                entity: id,
                to: neighbour,
            });
        }
    }
}
