//! How a proxy follows its entity's replicated state, by [`ProxyMode`]: set to the pose
//! (Fixed), given the velocities that carry it there (kinematic, see `dead_reckoning`), or
//! moved by a [`CustomProxy`]. An entity its owner moves kinematically (a platform) is
//! followed kinematically in the Fixed mode too, so what rests on it rides along.

use seam_sim::wire::EntityState;
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
}

impl Proxies {
    /// Sets the hook that moves proxies in [`ProxyMode::Custom`].
    pub(crate) fn set_custom(&mut self, proxy: Box<dyn CustomProxy>) {
        self.custom = Some(proxy);
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
