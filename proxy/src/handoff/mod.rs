//! Hand-offs: an entity moved to another owner by flipping its `cluster_id`, and everything
//! that keeps one from being lost on the way.
//!
//! An owner queues a hand-off ([`Handoffs::queue`], from game code or the authority policy);
//! its next replication frame carries the entity's final state with the new owner's id, and
//! the body becomes a proxy here ([`Handoffs::given`]). Until a frame of the new owner
//! mentions the entity, every replication frame repeats the hand-off (in transit), so it
//! survives a lost frame; what was given is remembered for a while (released), so that a late
//! repeat of an older hand-off to this cluster is not taken. A hand-off to this cluster whose
//! state is from a tick this world has not reached (the one it is about to step to, or later
//! while it catches up after a stall) is held until then (early).
//! Hand-offs a neighbour never took come back when it leaves or is taken for dead
//! ([`take_back`]); one a neighbour neither takes nor dies before within
//! `neighbour_timeout_ticks` comes back too ([`Handoffs::take_overdue`]), at the next epoch, so
//! the claim it comes back with outranks a late take there. Hand-offs go only to a neighbour
//! heard from lately and not gone that models the entity by the world map ([`check`]).
//!
//! Ownership has no gap at a hand-off: the giver stepped the body as its owner in the tick
//! whose frame hands it over, so it counts as the giver's until that tick ends
//! ([`Handoffs::given_last_tick`]); the taker counts it from the next tick
//! (`ClusterEvent::HandoffTaken::since`), however late its frame arrives.

use seam_sim::wire::{ClusterId, EntityId, EntityState, IdMap, PhysicsEventsFrame};
use seam_sim::{BodyRole, ClusterSim};

use crate::config::{ClusterConfig, ProxyMode};
use crate::error::ClusterError;
use crate::events::{ClusterEvent, Events};
use crate::neighbours::{NeighbourStatus, Neighbours};
use crate::replication::extent;

/// Ticks a hand-off this cluster made is remembered: long after any repeat of an older one
/// can still be in flight.
const RELEASED_FOR: u64 = 600;

/// Hand-offs held for a later tick at most (beyond, one is taken at once, as before holding):
/// bounds what a neighbour's frames can make this cluster keep.
const MAX_EARLY_HANDOFFS: usize = 1 << 16;

/// The role an entity's owner gives its body: the one its motion says (a kinematic body
/// stays kinematic with the velocity it was handed with).
pub(crate) fn owner_role(state: &EntityState) -> BodyRole {
    state.body.motion.owner_role()
}

/// Takes back, as cluster `me`'s again, an entity handed over in `handed` that its new owner
/// never took: the body as it was handed over (a Fixed proxy has lost its velocity since), at
/// the next epoch. Returns whether the world took it.
pub(crate) fn take_back(sim: &mut ClusterSim, me: ClusterId, handed: &EntityState) -> bool {
    let back = EntityState {
        cluster_id: me,
        epoch: handed.epoch + 1,
        ..*handed
    };
    sim.set_role(back.id, owner_role(&back)).is_ok() && sim.apply_state(&back).is_ok()
}

/// Hand-offs a live neighbour has not answered within `neighbour_timeout_ticks` come back (see
/// the module's text): counted and logged with the entity and the neighbour.
pub(crate) fn return_overdue(
    handoffs: &mut Handoffs,
    sim: &mut ClusterSim,
    config: &ClusterConfig,
    events: &mut Events,
) {
    let me = config.cluster_id;
    for handed in handoffs.take_overdue(sim.tick(), config.neighbour_timeout_ticks) {
        let to = handed.cluster_id;
        let back = take_back(sim, me, &handed);
        if back {
            events.emit(ClusterEvent::HandoffReturned {
                entity: handed.id,
                to,
            });
        }
        tracing::warn!(
            cluster = %config.label(me),
            entity = %config.entity_label(handed.id),
            neighbour = %config.label(to),
            handed_at = handed.tick,
            taken_back = back,
            "hand-off not taken within neighbour_timeout_ticks: it comes back"
        );
    }
}

/// Whether this cluster may hand `entity` to `to` now.
pub(crate) fn check(
    sim: &ClusterSim,
    config: &ClusterConfig,
    neighbours: &Neighbours,
    entity: EntityId,
    to: ClusterId,
) -> Result<(), ClusterError> {
    let refuse = |reason| ClusterError::Transfer { entity, to, reason };
    let info = sim.info(entity).ok_or(refuse("not in this world"))?;
    if info.owner != config.cluster_id {
        return Err(refuse("not owned by this cluster"));
    }
    if to == config.cluster_id {
        return Err(refuse("already owned here"));
    }
    if !config.neighbours.contains(&to) {
        return Err(refuse("not a neighbour"));
    }
    match neighbours.status(to) {
        Some(NeighbourStatus::Dead) => Err(refuse("the neighbour is taken for dead (silent)")),
        Some(NeighbourStatus::Left) => Err(refuse("the neighbour has left")),
        Some(NeighbourStatus::NotHeard) => Err(refuse(
            "the neighbour has not been heard from (not running yet?)",
        )),
        _ if !neighbours.answering(to, sim.tick(), crate::clock::monotonic_ns(), config) => Err(
            refuse("the neighbour has not been heard lately (stalled, or being taken for dead)"),
        ),
        _ if !models(sim, config, entity, to) => Err(refuse(
            "the neighbour does not model it: its extent is beyond the neighbour's region and \
             spread on the world map, so no proxy of it is there to take it over",
        )),
        _ => Ok(()),
    }
}

/// Whether `to` models `entity` by the world map: the entity's extent (as the interest rule
/// sweeps it) overlaps `to`'s region grown by its spread (its map entry's, or where that is 0,
/// not known, this cluster's own), so `to` holds a proxy of it from the frames it has read and
/// a hand-off turns that proxy into the body (the rule's other reasons to model, `to`'s own
/// bodies nearby and its watches, are not known here). Without `to` on the map, assumed.
fn models(sim: &ClusterSim, config: &ClusterConfig, entity: EntityId, to: ClusterId) -> bool {
    let Some(mapped) = config.world.iter().find(|c| c.id == to) else {
        return true;
    };
    let spread = if mapped.spread > 0.0 {
        mapped.spread
    } else {
        config.spread.max(0.0)
    };
    sim.state(entity).is_some_and(|state| {
        extent(&state, config.sweep_s()).overlaps(&mapped.region.grown(spread))
    })
}

/// How long a declined hand-off is not asked again: four neighbour timeouts, at least 240
/// ticks.
fn decline_span(config: &ClusterConfig) -> u64 {
    4 * config.neighbour_timeout_ticks.max(60)
}

/// This cluster's hand-offs: queued, in transit, released, and held early.
#[derive(Debug, Default)]
pub(crate) struct Handoffs {
    /// Entities to hand over at the next replication frame, and to whom.
    queued: IdMap<EntityId, ClusterId>,
    /// Hand-offs not yet answered: the state each carried (new owner, final pose, next epoch).
    /// Every replication frame repeats them until a frame of the new owner mentions the
    /// entity; until then the new owner's silence about the entity is not a departure.
    in_transit: IdMap<EntityId, EntityState>,
    /// The entities handed over in the frame of the tick this world last stepped: stepped here
    /// as owned in that tick, so still this cluster's until the next tick begins.
    given_last: Vec<EntityId>,
    /// Entities this cluster handed over, with the epoch they left at and the tick.
    released: IdMap<EntityId, (u32, u64)>,
    /// Hand-offs to this cluster and claims back on its entities from a later tick than this
    /// world's, by entity and epoch (an adopter's claim, then its return), with their senders.
    early: IdMap<(EntityId, u32), (EntityState, ClusterId)>,
    /// Entities whose hand-off came back untaken, with the cluster that did not take it and
    /// the tick it came back: the policy does not hand them there again for a while (a
    /// neighbour that cannot model a body, its shape unregistered there say, would leave it
    /// unowned each time).
    refused_by: IdMap<EntityId, (ClusterId, u64)>,
    /// Neighbours' entities whose states this cluster refused this tick because it cannot
    /// model them, by owner: told to the owner in the next events frame to it.
    unmodelled: IdMap<ClusterId, Vec<EntityId>>,
}

impl Handoffs {
    /// Notes that this cluster refused a state of `entity`, of `owner`'s, as one it cannot
    /// model (its shape unregistered here).
    pub(crate) fn cannot_model(&mut self, owner: ClusterId, entity: EntityId) {
        let refused = self.unmodelled.entry(owner).or_default();
        if !refused.contains(&entity) {
            refused.push(entity);
        }
    }

    /// The entities of `owner`'s this cluster could not model since the last call.
    pub(crate) fn take_unmodelled(&mut self, owner: ClusterId) -> Vec<EntityId> {
        self.unmodelled.swap_remove(&owner).unwrap_or_default()
    }

    /// Takes in the neighbours' word, in `frames`, of this cluster's entities they cannot
    /// model: none is handed to them (by the policy, or by game code) for a while from `tick`.
    /// What was declined longer ago than that is forgotten.
    pub(crate) fn hear_unmodelled(
        &mut self,
        frames: &[(PhysicsEventsFrame, u64)],
        tick: u64,
        config: &ClusterConfig,
    ) {
        for (frame, _) in frames {
            for &entity in &frame.unmodelled {
                self.refused_by.insert(entity, (frame.from, tick));
            }
        }
        let span = decline_span(config);
        self.refused_by
            .retain(|_, &mut (_, at)| tick.saturating_sub(at) < span);
    }

    /// Whether a hand-off of `entity` to `to` came back untaken, or `to` said it cannot
    /// model the entity, lately: within four neighbour timeouts (at least 240 ticks) of
    /// `tick`.
    pub(crate) fn declined_by(
        &self,
        entity: EntityId,
        to: ClusterId,
        tick: u64,
        config: &ClusterConfig,
    ) -> bool {
        let span = decline_span(config);
        self.refused_by
            .get(&entity)
            .is_some_and(|&(by, at)| by == to && tick.saturating_sub(at) < span)
    }

    /// Queues `entity` to be handed to `to` at the next replication frame (checked by
    /// [`check`] first).
    pub(crate) fn queue(&mut self, entity: EntityId, to: ClusterId) {
        self.queued.insert(entity, to);
    }

    /// Whether a hand-off of `entity` is queued.
    pub(crate) fn is_queued(&self, entity: EntityId) -> bool {
        self.queued.contains_key(&entity)
    }

    /// Gives the queued entities among `states` (this frame's) their new owner and the next
    /// epoch, and returns those states: the new owner rides with the final pose and
    /// velocity, read before the body becomes a proxy (a Fixed body loses its velocity).
    pub(crate) fn mark(&self, states: &mut [EntityState]) -> Vec<EntityState> {
        let mut handing = Vec::new();
        for state in states {
            if let Some(&to) = self.queued.get(&state.id) {
                state.cluster_id = to;
                state.epoch += 1;
                handing.push(*state);
            }
        }
        handing
    }

    /// The hand-offs in transit, which every replication frame repeats.
    pub(crate) fn in_transit(&self) -> impl Iterator<Item = EntityState> + '_ {
        self.in_transit.values().copied()
    }

    /// Whether `entity` is in a hand-off from this cluster not yet answered.
    pub(crate) fn is_in_transit(&self, entity: EntityId) -> bool {
        self.in_transit.contains_key(&entity)
    }

    /// The frame carrying `handing` went out at `tick`: each body becomes a proxy of its new
    /// owner (`role`), in transit until that owner mentions it. The queue is emptied.
    pub(crate) fn given(
        &mut self,
        handing: Vec<EntityState>,
        tick: u64,
        mode: ProxyMode,
        sim: &mut ClusterSim,
        events: &mut Events,
    ) -> Result<(), ClusterError> {
        self.queued.clear();
        for handed in handing {
            let entity = handed.id;
            sim.set_authority(entity, handed.cluster_id, handed.epoch)?;
            sim.set_role(entity, mode.role_for(handed.body.motion))?;
            self.in_transit.insert(entity, handed);
            self.given_last.push(entity);
            self.released.insert(entity, (handed.epoch, tick));
            events.emit(ClusterEvent::HandoffGiven {
                entity,
                to: handed.cluster_id,
            });
        }
        self.released
            .retain(|_, &mut (_, at)| tick.saturating_sub(at) <= RELEASED_FOR);
        Ok(())
    }

    /// A new tick begins: the bodies handed over in the last one are the new owners' now.
    pub(crate) fn new_tick(&mut self) {
        self.given_last.clear();
    }

    /// The entities handed over in the frame of the tick this world last stepped (this
    /// cluster's until the next tick begins).
    pub(crate) fn given_last_tick(&self) -> &[EntityId] {
        &self.given_last
    }

    /// Takes out the hand-offs in transit that have waited more than `bound` ticks at `tick`
    /// for an answer from a neighbour still taken for alive: it is not taking them.
    pub(crate) fn take_overdue(&mut self, tick: u64, bound: u64) -> Vec<EntityState> {
        let overdue: Vec<EntityState> = self
            .in_transit
            .values()
            .filter(|handed| tick.saturating_sub(handed.tick) > bound)
            .copied()
            .collect();
        for handed in &overdue {
            self.in_transit.swap_remove(&handed.id);
            self.refused_by.insert(handed.id, (handed.cluster_id, tick));
        }
        overdue
    }

    /// A frame of `from` mentioning the entities `mentioned` answers the hand-offs to it of
    /// those entities.
    pub(crate) fn answered_by<I: Iterator<Item = EntityId>>(
        &mut self,
        from: ClusterId,
        mentioned: impl FnOnce() -> I,
    ) {
        if self
            .in_transit
            .values()
            .any(|handed| handed.cluster_id == from)
        {
            let mentioned: IdMap<EntityId, ()> = mentioned().map(|id| (id, ())).collect();
            self.in_transit
                .retain(|id, handed| handed.cluster_id != from || !mentioned.contains_key(id));
        }
    }

    /// Takes out the hand-offs to `neighbour` in transit (it left without taking them).
    pub(crate) fn take_in_transit_to(&mut self, neighbour: ClusterId) -> Vec<EntityState> {
        let unanswered: Vec<EntityState> = self
            .in_transit
            .values()
            .filter(|handed| handed.cluster_id == neighbour)
            .copied()
            .collect();
        for handed in &unanswered {
            self.in_transit.swap_remove(&handed.id);
        }
        unanswered
    }

    /// Takes out the hand-off of `entity` in transit, if there is one.
    pub(crate) fn take_in_transit(&mut self, entity: EntityId) -> Option<EntityState> {
        self.in_transit.swap_remove(&entity)
    }

    /// Forgets the hand-offs in transit to `dead`: those it took are its entities' business
    /// now.
    pub(crate) fn forget_in_transit_to(&mut self, dead: ClusterId) {
        self.in_transit
            .retain(|_, handed| handed.cluster_id != dead);
    }

    /// Whether this cluster handed `entity` over lately at an epoch later than `epoch`.
    pub(crate) fn released_after(&self, entity: EntityId, epoch: u32) -> bool {
        (self.released.get(&entity)).is_some_and(|&(at, _)| epoch < at)
    }

    /// Whether a hand-off of `entity` to this cluster at `epoch` is a repeat of one from
    /// before this cluster gave the entity away again.
    pub(crate) fn was_released(&self, entity: EntityId, epoch: u32) -> bool {
        self.released
            .get(&entity)
            .is_some_and(|&(released, _)| epoch <= released)
    }

    /// Holds a hand-off to this cluster (or a claim back) from a tick this world has not
    /// reached until that tick (see `Reconcile::hold_early`); false when too many are held.
    pub(crate) fn hold_early(&mut self, state: &EntityState, from: ClusterId) -> bool {
        let key = (state.id, state.epoch);
        let room = self.early.len() < MAX_EARLY_HANDOFFS || self.early.contains_key(&key);
        if room {
            self.early.insert(key, (*state, from));
        }
        room
    }

    /// Takes the held hand-offs and claims this world's `tick` reached or that are beyond
    /// `until` (no longer catching up to them), with their senders, oldest epoch first.
    pub(crate) fn take_early(&mut self, tick: u64, until: u64) -> Vec<(EntityState, ClusterId)> {
        let mut due = Vec::new();
        self.early.retain(|_, held| {
            let keep = held.0.tick > tick && held.0.tick <= until;
            if !keep {
                due.push(*held);
            }
            keep
        });
        due.sort_by_key(|(state, _)| state.epoch);
        due
    }
}
