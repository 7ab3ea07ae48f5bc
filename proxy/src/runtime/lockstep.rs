//! Stepping several clusters of one process in lock-step.

use std::time::Duration;

use seam_sim::{PhysicsHandle, TickContext};

use crate::cluster::Cluster;
use crate::error::ClusterError;

/// Runs one tick of every cluster, in order, each in lock-step: a cluster waits (up to
/// `timeout`) for its neighbours' frames of the previous tick, counted, not timed. `user` is
/// called with the cluster's index in `clusters`.
pub fn lockstep_round(
    clusters: &mut [Cluster],
    timeout: Duration,
    mut user: impl FnMut(usize, &TickContext<'_>, &mut PhysicsHandle<'_>),
) -> Result<(), ClusterError> {
    for (index, cluster) in clusters.iter_mut().enumerate() {
        cluster.tick_lockstep(timeout, |context, physics| user(index, context, physics))?;
    }
    Ok(())
}
