//! How a proxy follows its entity's replicated state, by [`ProxyMode`]: set to the pose
//! (Fixed), given the velocities that carry it there (kinematic, see `dead_reckoning`), or
//! moved by a [`CustomProxy`]. An entity its owner moves kinematically (a platform) is
//! followed kinematically in the Fixed mode too, so what rests on it rides along.

use seam_sim::wire::{EntityId, EntityState, IdMap};
use seam_sim::{BodyRole, ClusterSim, SimError};

use super::dead_reckoning;
use crate::config::{ClusterConfig, ProxyMode};

/// Moves proxies in [`ProxyMode::Custom`].
pub trait CustomProxy {
    /// Brings the proxy of `state.id` in `sim` to the replicated `state`.
    fn update(&mut self, sim: &mut ClusterSim, state: &EntityState) -> Result<(), SimError>;
}

/// The proxies' way of following their entities.
#[derive(Default)]
pub(crate) struct Proxies {
    custom: Option<Box<dyn CustomProxy>>,
    /// Proxies whose owner handed them to a third cluster, with the tick of the state that
    /// said so: the new owner's frames up to that tick are from before it took the entity, so
    /// their silence about it is no departure (see [`Proxies::departed`]).
    handed_on: IdMap<EntityId, u64>,
}

impl Proxies {
    /// Sets the hook that moves proxies in [`ProxyMode::Custom`].
    pub(crate) fn set_custom(&mut self, proxy: Box<dyn CustomProxy>) {
        self.custom = Some(proxy);
    }

    /// Notes that `state`, from its old owner, hands its entity to a third cluster.
    pub(crate) fn handed_on(&mut self, state: &EntityState) {
        self.handed_on.insert(state.id, state.tick);
    }

    /// Whether a whole frame of tick `frame_tick` from the entity's owner that does not list
    /// `entity` means it has left. A frame from before the owner took the entity over (the
    /// hand-off from its old owner came in the same receive, or a tick ahead of the taker's
    /// first frame as owner) does not: at a corner, the entity would vanish for a tick or two
    /// from every third world, with the contacts it makes there.
    pub(crate) fn departed(&mut self, entity: EntityId, frame_tick: u64) -> bool {
        match self.handed_on.get(&entity) {
            Some(&handed) if frame_tick <= handed => false,
            Some(_) => {
                self.handed_on.swap_remove(&entity);
                true
            }
            None => true,
        }
    }

    /// Forgets what was noted of `entity` (its owner has listed it, or it left this world).
    pub(crate) fn forget(&mut self, entity: EntityId) {
        self.handed_on.swap_remove(&entity);
    }

    /// Brings the proxy of `state.id` to the replicated `state`.
    pub(crate) fn follow(
        &mut self,
        sim: &mut ClusterSim,
        config: &ClusterConfig,
        state: &EntityState,
    ) -> Result<(), SimError> {
        let now = sim.info(state.id).map(|info| info.role);
        if now == Some(BodyRole::Dynamic) {
            // Simulated here for now (see `seam_sim::coupling`): set to what its owner says.
            return sim.apply_state(state);
        }
        let role = config.proxy_mode.role_for(state.body.motion);
        if now.is_some_and(|now| now != role) {
            // Its owner moves it another way than before (a platform made dynamic, say).
            sim.set_role(state.id, role)?;
        }
        match config.proxy_mode {
            ProxyMode::Fixed if role == BodyRole::Fixed => sim.apply_state(state),
            ProxyMode::Fixed | ProxyMode::KinematicVelocityBased => {
                // Aim where the entity will be at the next update, so the proxy moves with it in
                // between (see `dead_reckoning`).
                let Some(now) = sim.state(state.id) else {
                    return Err(SimError::UnknownEntity(state.id));
                };
                let ticks = config.replication_interval.max(1) as f32;
                let aim = dead_reckoning::aim(&now, state, config.dt * ticks, ticks);
                sim.apply_state(&aim)
            }
            ProxyMode::Custom => match self.custom.as_mut() {
                Some(proxy) => proxy.update(sim, state),
                None => sim.apply_state(state),
            },
        }
    }
}
