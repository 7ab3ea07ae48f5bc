//! [`SimConfig`]: the settings of one cluster's world.

use crate::wire::ClusterId;

/// Settings of one cluster's world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimConfig {
    /// This cluster.
    pub cluster_id: ClusterId,
    /// Step length in seconds.
    pub dt: f32,
    /// Gravity, m/s².
    pub gravity: [f32; 3],
    /// Largest linear speed Rapier lets a body keep after a solver substep, m/s. Rapier's own
    /// default is 400 m/s, below a rifle bullet; raise it for fast projectiles (and give them
    /// CCD).
    pub max_linear_velocity: f32,
    /// Largest magnitude any component of a write may have (an impulse in N·s, a velocity in
    /// m/s, a position in m…): beyond it the write is refused with
    /// [`SimError::BeyondBound`](crate::SimError::BeyondBound), here and where it is routed, so
    /// an absurd push is an error rather than a body that stops or vanishes. The proxy layer
    /// sets it from `ClusterConfig::max_magnitude` (the bound on what is accepted from other
    /// clusters); default 1e6.
    pub max_op_magnitude: f32,
}

impl SimConfig {
    /// 60 Hz, Earth gravity along −y, Rapier's default speed cap of 400 m/s.
    pub fn new(cluster_id: ClusterId) -> Self {
        Self {
            cluster_id,
            dt: 1.0 / 60.0,
            gravity: [0.0, -9.81, 0.0],
            max_linear_velocity: 400.0,
            max_op_magnitude: 1.0e6,
        }
    }
}
