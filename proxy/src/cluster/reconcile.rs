//! Bringing the world in line with a neighbour's replication frame: hand-offs in, proxies
//! spawned, moved and despawned.

use seam_sim::BodyRole;
use seam_sim::wire::{ClusterId, EntityId, EntityState, IdMap};

use crate::config::ProxyMode;
use crate::dead_reckoning;
use crate::inbox::HeldReplication;
use crate::interest::extent;

use super::{Cluster, within};

/// Hand-offs held for a later tick at most (beyond, one is taken at once, as before holding):
/// bounds what a neighbour's frames can make this cluster keep.
const MAX_EARLY_HANDOFFS: usize = 1 << 16;

/// The role an entity's owner gives its body: dynamic if it is simulated, else Fixed (a body
/// its old owner moved itself stands still until game code here moves it).
pub(super) fn owner_role(state: &EntityState) -> BodyRole {
    if state.body.simulated {
        BodyRole::Dynamic
    } else {
        BodyRole::Fixed
    }
}

impl Cluster {
    pub(super) fn proxy_role(&self) -> BodyRole {
        match self.config.proxy_mode {
            ProxyMode::Fixed => BodyRole::Fixed,
            ProxyMode::KinematicVelocityBased => BodyRole::KinematicVelocityBased,
            ProxyMode::Custom => BodyRole::KinematicPositionBased,
        }
    }

    /// How long a replicated pose stands before the next frame can replace it, seconds: the
    /// sweep an extent is grown by (see `crate::interest`).
    pub(super) fn sweep_s(&self) -> f32 {
        (self.config.replication_interval.max(1) + 1) as f32 * self.config.dt
    }

    pub(super) fn visible(&self, state: &EntityState) -> bool {
        self.interest.covers(&extent(state, self.sweep_s()))
    }

    /// Brings the world in line with one neighbour's replication frame.
    pub(super) fn reconcile(&mut self, frame: &HeldReplication) {
        let (me, from) = (self.config.cluster_id, frame.from);
        let mut listed: IdMap<EntityId, ()> = IdMap::default();
        // A hand-off this cluster made to `from` is answered once `from` mentions the entity.
        if self.handed.values().any(|handed| handed.cluster_id == from) {
            let mentioned: IdMap<EntityId, ()> = frame.ids().map(|id| (id, ())).collect();
            self.handed
                .retain(|id, handed| handed.cluster_id != from || !mentioned.contains_key(id));
        }
        for state in frame.states() {
            let Ok(state) = state else {
                // A record that does not read (an index out of its table, a bad rotation).
                self.stats.states_rejected += 1;
                continue;
            };
            let state = &state;
            let limit = self.config.max_magnitude;
            let absurd = ![state.position, state.linvel, state.angvel]
                .into_iter()
                .all(|v| within(v, limit));
            if absurd || seam_sim::check_state(state).is_err() {
                self.stats.states_rejected += 1;
                continue;
            }
            if self.hold_early_handoff(state, from) {
                listed.insert(state.id, ());
                continue;
            }
            let known = self.sim.info(state.id).map(|i| (i.owner, i.epoch));
            let outcome = self.reconcile_state(state, from, known, &mut listed);
            if outcome.is_err() {
                self.stats.states_rejected += 1;
                tracing::debug!(
                    cluster = %me,
                    %from,
                    entity = %state.id,
                    claimed_owner = %state.cluster_id,
                    known = ?known,
                    epoch = state.epoch,
                    "state rejected"
                );
            }
        }
        // Proxies of this neighbour that its frame no longer lists have left (or were
        // destroyed): nothing else is modelled. A delta frame without its keyframe lists only
        // what changed, so it says nothing of the others.
        if !frame.is_whole() {
            return;
        }
        self.despawn_departed(from, &listed);
    }

    /// A hand-off to this cluster whose state is from the tick this world is about to step to
    /// (free-running: the old owner stepped the body and published after this cluster's last
    /// tick, as between staggered pods): held until that tick, so the body is taken where it
    /// is at the tick it is taken and not stepped twice for one tick. Its proxy stays where the
    /// last frame put it. A state further ahead means this world is behind its neighbours
    /// (stalled, or catching up): holding it would leave the body with no owner for as long,
    /// so it is taken at once, as it always was. Returns whether `state` was held.
    fn hold_early_handoff(&mut self, state: &EntityState, from: ClusterId) -> bool {
        let early = self.free_running
            && state.cluster_id == self.config.cluster_id
            && state.tick == self.sim.tick() + 1
            && self.early_handoffs.len() < MAX_EARLY_HANDOFFS;
        if early {
            self.early_handoffs.insert(state.id, (*state, from));
        }
        early
    }

    /// Takes the held hand-offs whose tick this world has reached (see
    /// [`Self::hold_early_handoff`]).
    pub(super) fn take_early_handoffs(&mut self) {
        let tick = self.sim.tick();
        let due: Vec<EntityId> = self
            .early_handoffs
            .iter()
            .filter(|(_, (state, _))| state.tick <= tick)
            .map(|(id, _)| *id)
            .collect();
        for id in due {
            let Some((state, from)) = self.early_handoffs.swap_remove(&id) else {
                continue;
            };
            let known = self.sim.info(id).map(|i| (i.owner, i.epoch));
            if self
                .reconcile_state(&state, from, known, &mut IdMap::default())
                .is_err()
            {
                self.stats.states_rejected += 1;
            }
        }
    }

    /// Brings the world in line with one state of `from`'s frame; `known` is what the world
    /// had of the entity (owner, epoch). Proxies listed are noted in `listed`.
    fn reconcile_state(
        &mut self,
        state: &EntityState,
        from: ClusterId,
        known: Option<(ClusterId, u32)>,
        listed: &mut IdMap<EntityId, ()>,
    ) -> Result<(), ()> {
        let me = self.config.cluster_id;
        {
            match known {
                // Handed (back) to this cluster, which owns it already — a repeat, or a return
                // to a pod that was only stalled and kept simulating it: nothing to do but
                // learn the epoch.
                Some((owner, epoch)) if owner == me && state.cluster_id == me => {
                    if state.epoch > epoch {
                        let _ = self.sim.set_authority(state.id, me, state.epoch);
                    }
                    Ok(())
                }
                // Older than what this world knows (a hand-off repeated after the entity moved
                // on): not news.
                Some((_, epoch)) if state.epoch < epoch => Ok(()),
                // A repeat of the hand-off this world already applied.
                Some((owner, epoch))
                    if owner != from && state.epoch == epoch && state.cluster_id == owner =>
                {
                    Ok(())
                }
                // Only an entity's owner speaks for it: a frame claiming another cluster's
                // (or this cluster's) entity is ignored.
                Some((owner, _)) if owner != from => Err(()),
                Some(_) => {
                    listed.insert(state.id, ());
                    self.update_known(state, from)
                }
                None if state.cluster_id == me => {
                    let released = self.released.get(&state.id);
                    if released.is_some_and(|&(epoch, _)| state.epoch <= epoch) {
                        // A repeat of a hand-off to this cluster from before it gave the entity
                        // away again.
                        Ok(())
                    } else {
                        self.take_over_unseen(state)
                    }
                }
                None if state.cluster_id == from && self.visible(state) => {
                    listed.insert(state.id, ());
                    let role = self.proxy_role();
                    self.sim
                        .spawn(state, role)
                        .map(|()| self.stats.proxies_spawned += 1)
                        .map_err(|_| ())
                }
                None => Ok(()),
            }
        }
    }

    /// Despawns the proxies of `from` its whole frame did not list (and that are not in a
    /// hand-off from this cluster).
    fn despawn_departed(&mut self, from: ClusterId, listed: &IdMap<EntityId, ()>) {
        let departed: Vec<EntityId> = self
            .sim
            .entities()
            .filter(|(id, info)| info.owner == from && !listed.contains_key(id))
            .filter(|(id, _)| !self.handed.contains_key(id))
            .map(|(id, _)| id)
            .collect();
        for id in departed {
            if self.sim.despawn(id).is_ok() {
                self.stats.proxies_despawned += 1;
            }
        }
    }

    /// A state from the current owner of an entity this world already has.
    pub(super) fn update_known(&mut self, state: &EntityState, from: ClusterId) -> Result<(), ()> {
        let me = self.config.cluster_id;
        if state.cluster_id == me {
            // Handed to this cluster: the proxy becomes the body, in place, with the final pose
            // and velocity the old owner sent.
            self.sim
                .set_role(state.id, owner_role(state))
                .map_err(|_| ())?;
            self.sim.apply_state(state).map_err(|_| ())?;
            self.stats.handoffs_in += 1;
            self.log_handoff(state.id, true);
            return Ok(());
        }
        if state.cluster_id != from {
            // Handed to a third cluster: writes are routed there from now on.
            self.sim
                .set_authority(state.id, state.cluster_id, state.epoch)
                .map_err(|_| ())?;
        }
        if !self.visible(state) {
            self.sim.despawn(state.id).map_err(|_| ())?;
            self.stats.proxies_despawned += 1;
            return Ok(());
        }
        self.update_proxy(state)
    }

    /// Handed to this cluster an entity it had no proxy of: it starts as the body.
    pub(super) fn take_over_unseen(&mut self, state: &EntityState) -> Result<(), ()> {
        self.sim.spawn(state, owner_role(state)).map_err(|_| ())?;
        self.stats.handoffs_in += 1;
        self.log_handoff(state.id, true);
        Ok(())
    }

    pub(super) fn update_proxy(&mut self, state: &EntityState) -> Result<(), ()> {
        self.predictions.state_applied(state.id);
        let coupled = self
            .sim
            .info(state.id)
            .is_some_and(|info| info.role == BodyRole::Dynamic);
        if coupled {
            // Simulated here for now (see `seam_sim::coupling`): set to what its owner says.
            return self.sim.apply_state(state).map_err(|_| ());
        }
        match self.config.proxy_mode {
            ProxyMode::Fixed => self.sim.apply_state(state).map_err(|_| ()),
            ProxyMode::KinematicVelocityBased => {
                // Aim where the entity will be at the next update, so the proxy moves with it in
                // between (see `crate::dead_reckoning`).
                let now = self.sim.state(state.id).ok_or(())?;
                let ticks = self.config.replication_interval.max(1) as f32;
                let aim = dead_reckoning::aim(&now, state, self.config.dt * ticks, ticks);
                self.sim.apply_state(&aim).map_err(|_| ())
            }
            ProxyMode::Custom => match self.custom_proxy.as_mut() {
                Some(proxy) => proxy.update(&mut self.sim, state).map_err(|_| ()),
                None => self.sim.apply_state(state).map_err(|_| ()),
            },
        }
    }
}
