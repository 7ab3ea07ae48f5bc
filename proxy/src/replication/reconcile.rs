//! Bringing the world in line with a neighbour's replication frame: hand-offs in, proxies
//! spawned, moved and despawned.

use seam_sim::wire::{ClusterId, EntityId, EntityState, IdMap};
use seam_sim::{BodyRole, ClusterSim, SimError};

use super::interest::{Interest, extent};
use super::proxies::Proxies;
use crate::config::ClusterConfig;
use crate::contacts::Predictions;
use crate::events::{ClusterEvent, Events};
use crate::handoff::{Handoffs, owner_role};
use crate::inbox::HeldReplication;

/// What reconciling reads and changes: the world and the parts that follow it.
pub(crate) struct Reconcile<'a> {
    pub(crate) sim: &'a mut ClusterSim,
    pub(crate) config: &'a ClusterConfig,
    pub(crate) events: &'a mut Events,
    pub(crate) handoffs: &'a mut Handoffs,
    pub(crate) interest: &'a Interest,
    pub(crate) proxies: &'a mut Proxies,
    pub(crate) predictions: &'a mut Predictions,
    /// Free-running, the latest tick a hand-off to this cluster or a claim on one of its
    /// entities from a tick this world has not reached is held until (see `hold_early`).
    pub(crate) hold_until: Option<u64>,
    /// Entities this cluster owned and yielded to a later claim (see `yield_to`).
    pub(crate) yielded: Vec<EntityId>,
}

/// A state this cluster does not take (rejected, counted).
struct Refused;

impl Reconcile<'_> {
    fn visible(&self, state: &EntityState) -> bool {
        self.interest.covers(&extent(state, self.config.sweep_s()))
    }

    fn rejected(&mut self, from: ClusterId) {
        self.events.emit(ClusterEvent::StateRejected { from });
    }

    /// Spawns `state`'s body with `role`; one this world cannot model (a catalog shape it has
    /// not registered) is noted for its owner `from`, who then hands it nowhere near here.
    fn spawn(
        &mut self,
        state: &EntityState,
        role: BodyRole,
        from: ClusterId,
    ) -> Result<(), Refused> {
        match self.sim.spawn(state, role) {
            Ok(()) => Ok(()),
            Err(SimError::UnknownShapeOf { .. }) => {
                self.handoffs.cannot_model(from, state.id);
                Err(Refused)
            }
            Err(_) => Err(Refused),
        }
    }

    /// Brings the world in line with one neighbour's replication frame.
    pub(crate) fn frame(&mut self, frame: &HeldReplication) {
        let from = frame.from;
        let mut listed: IdMap<EntityId, ()> = IdMap::default();
        // A hand-off this cluster made to `from` is answered once `from` mentions the entity.
        self.handoffs.answered_by(from, || frame.ids());
        for state in frame.states() {
            let Ok(state) = state else {
                // A record that does not read (an index out of its table, a bad rotation).
                self.rejected(from);
                continue;
            };
            let absurd = ![state.position, state.linvel, state.angvel]
                .into_iter()
                .all(|v| self.config.within_bound(v));
            if absurd || seam_sim::check_state(&state).is_err() {
                self.rejected(from);
                continue;
            }
            let known = self.sim.info(state.id).map(|i| (i.owner, i.epoch));
            if self.hold_early(&state, from, known) {
                listed.insert(state.id, ());
                continue;
            }
            if self.state(&state, from, known, &mut listed).is_err() {
                self.rejected(from);
                tracing::debug!(
                    cluster = %self.config.label(self.config.cluster_id),
                    from = %self.config.label(from),
                    entity = %self.config.entity_label(state.id),
                    claimed_owner = %self.config.label(state.cluster_id),
                    known = ?known,
                    epoch = state.epoch,
                    "state rejected"
                );
            }
        }
        // Proxies of this neighbour that its frame no longer lists have left (or were
        // destroyed): nothing else is modelled. A delta frame without its keyframe lists only
        // what changed, so it says nothing of the others.
        if frame.is_whole() {
            self.despawn_departed(from, frame.tick, &listed);
        }
    }

    /// A hand-off to this cluster, or a claim back at a later epoch of an entity this cluster
    /// owns, whose state is from a tick this world has not reached (free-running) is held until
    /// that tick (see [`Handoffs::hold_early`]): the tick it is about to step to, or a later
    /// one while it catches up after a stall (`CatchUp`). Taken at once, a handed body would
    /// be stepped again through ticks its giver stepped it in as owner, and a claimed one
    /// would be given up for ticks nobody steps it in (its adopter's claim speaks from the
    /// tick it adopted, this world is still behind it), so either would be counted by two
    /// pods or by none. A state further ahead than `hold_until` is from a neighbour that
    /// counts its ticks from another start: taken at once. Returns whether `state` was held.
    fn hold_early(
        &mut self,
        state: &EntityState,
        from: ClusterId,
        known: Option<(ClusterId, u32)>,
    ) -> bool {
        let me = self.config.cluster_id;
        let claimed_back = known.is_some_and(|(owner, epoch)| {
            owner == me && state.cluster_id == from && state.epoch > epoch
        });
        self.hold_until.is_some_and(|until| {
            (state.cluster_id == me || claimed_back)
                && state.tick > self.sim.tick()
                && state.tick <= until
        }) && self.handoffs.hold_early(state, from)
    }

    /// Takes the held hand-offs whose tick this world has reached.
    pub(crate) fn early_handoffs(&mut self) {
        let tick = self.sim.tick();
        let until = self.hold_until.unwrap_or(tick);
        for (state, from) in self.handoffs.take_early(tick, until) {
            let known = self.sim.info(state.id).map(|i| (i.owner, i.epoch));
            if self
                .state(&state, from, known, &mut IdMap::default())
                .is_err()
            {
                self.rejected(from);
            }
        }
    }

    /// Brings the world in line with one state of `from`'s frame; `known` is what the world
    /// had of the entity (owner, epoch). Proxies listed are noted in `listed`.
    fn state(
        &mut self,
        state: &EntityState,
        from: ClusterId,
        known: Option<(ClusterId, u32)>,
        listed: &mut IdMap<EntityId, ()>,
    ) -> Result<(), Refused> {
        let me = self.config.cluster_id;
        match known {
            // Handed (back) to this cluster, which owns it already — a repeat, or a return to
            // a pod that was only stalled and kept simulating it: nothing to do but learn the
            // epoch.
            Some((owner, epoch)) if owner == me && state.cluster_id == me => {
                if state.epoch > epoch {
                    let _ = self.sim.set_authority(state.id, me, state.epoch);
                }
                Ok(())
            }
            // Older than what this world knows (a hand-off repeated after the entity moved
            // on, or a pod catching up after a stall still listing what was adopted from it
            // and handed back since): not news, but still listed, so not departed.
            Some((_, epoch)) if state.epoch < epoch => {
                listed.insert(state.id, ());
                Ok(())
            }
            // A repeat of the hand-off this world already applied.
            Some((owner, epoch))
                if owner != from && state.epoch == epoch && state.cluster_id == owner =>
            {
                Ok(())
            }
            // Claimed back, at a later epoch, by the cluster that handed it here: it gave up
            // waiting for this cluster's answer (see `Handoffs::take_overdue`), and its claim
            // outranks this copy, which becomes its proxy.
            Some((owner, epoch))
                if owner == me && state.cluster_id == from && state.epoch > epoch =>
            {
                self.yield_to(state, from, listed)
            }
            // Only an entity's owner speaks for it: a frame claiming another cluster's (or
            // this cluster's) entity is ignored.
            Some((owner, _)) if owner != from => Err(Refused),
            Some(_) => {
                listed.insert(state.id, ());
                self.known(state, from)
            }
            // A repeat of a hand-off to this cluster from before it gave the entity away
            // again.
            None if state.cluster_id == me && self.handoffs.was_released(state.id, state.epoch) => {
                Ok(())
            }
            // Handed to this cluster an entity it had no proxy of: it starts as the body
            // (counted: its surroundings here were not modelled around it before).
            None if state.cluster_id == me => {
                self.spawn(state, owner_role(state), from)?;
                self.events.emit(ClusterEvent::HandoffWithoutProxy {
                    entity: state.id,
                    from,
                });
                self.taken(state, from);
                Ok(())
            }
            // A state from before this cluster's own later hand-off of the entity (a pod
            // catching up after a stall) is stale: no proxy is made of it.
            None if state.cluster_id == from
                && self.visible(state)
                && !self.handoffs.released_after(state.id, state.epoch) =>
            {
                listed.insert(state.id, ());
                self.spawn(
                    state,
                    self.config.proxy_mode.role_for(state.body.motion),
                    from,
                )?;
                self.events
                    .emit(ClusterEvent::ProxySpawned { entity: state.id });
                Ok(())
            }
            None => Ok(()),
        }
    }

    fn taken(&mut self, state: &EntityState, from: ClusterId) {
        self.events.emit(ClusterEvent::HandoffTaken {
            entity: state.id,
            from,
            since: state.tick + 1,
        });
    }

    /// Gives up this cluster's copy of an entity `from` claims back at a later epoch: it
    /// becomes `from`'s proxy, where `from` says it is.
    fn yield_to(
        &mut self,
        state: &EntityState,
        from: ClusterId,
        listed: &mut IdMap<EntityId, ()>,
    ) -> Result<(), Refused> {
        self.sim
            .set_authority(state.id, from, state.epoch)
            .and_then(|()| {
                self.sim
                    .set_role(state.id, self.config.proxy_mode.role_for(state.body.motion))
            })
            .map_err(|_| Refused)?;
        self.events.emit(ClusterEvent::HandoffYielded {
            entity: state.id,
            to: from,
        });
        self.yielded.push(state.id);
        tracing::warn!(
            cluster = %self.config.label(self.config.cluster_id),
            entity = %self.config.entity_label(state.id),
            to = %self.config.label(from),
            "entity claimed back by the cluster that handed it here: this copy is its proxy now"
        );
        listed.insert(state.id, ());
        self.known(state, from)
    }

    /// A state from the current owner of an entity this world already has.
    fn known(&mut self, state: &EntityState, from: ClusterId) -> Result<(), Refused> {
        if state.cluster_id == self.config.cluster_id {
            // Handed to this cluster: the proxy becomes the body, in place, with the final pose
            // and velocity the old owner sent.
            self.proxies.forget(state.id);
            self.sim
                .set_role(state.id, owner_role(state))
                .map_err(|_| Refused)?;
            self.sim.apply_state(state).map_err(|_| Refused)?;
            self.taken(state, from);
            return Ok(());
        }
        if state.cluster_id != from {
            // Handed to a third cluster: writes are routed there from now on.
            self.sim
                .set_authority(state.id, state.cluster_id, state.epoch)
                .map_err(|_| Refused)?;
            self.proxies.handed_on(state);
        } else {
            self.proxies.forget(state.id);
        }
        if !self.visible(state) {
            self.proxies.forget(state.id);
            self.sim.despawn(state.id).map_err(|_| Refused)?;
            self.events
                .emit(ClusterEvent::ProxyDespawned { entity: state.id });
            return Ok(());
        }
        self.predictions.state_applied(state.id);
        self.proxies
            .follow(self.sim, self.config, state)
            .map_err(|_| Refused)
    }

    /// Despawns the proxies of `from` its whole frame of `tick` did not list (and that are not
    /// in a hand-off from this cluster, nor handed to `from` after that tick).
    fn despawn_departed(&mut self, from: ClusterId, tick: u64, listed: &IdMap<EntityId, ()>) {
        let unlisted: Vec<EntityId> = self
            .sim
            .entities()
            .filter(|(id, info)| info.owner == from && !listed.contains_key(id))
            .filter(|(id, _)| !self.handoffs.is_in_transit(*id))
            .map(|(id, _)| id)
            .collect();
        let proxies = &mut *self.proxies;
        let departed: Vec<EntityId> = unlisted
            .into_iter()
            .filter(|&id| proxies.departed(id, tick))
            .collect();
        for entity in departed {
            if self.sim.despawn(entity).is_ok() {
                self.events.emit(ClusterEvent::ProxyDespawned { entity });
            }
        }
    }
}
