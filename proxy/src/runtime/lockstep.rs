//! Stepping several clusters of one process in lock-step.

use std::time::Duration;

use seam_sim::{PhysicsHandle, TickContext};

use crate::cluster::Cluster;
use crate::error::ClusterError;

/// Runs one tick of every cluster, in order, each in lock-step: a cluster waits (up to
/// `timeout`) for its neighbours' frames of the previous tick, counted, not timed. `user` is
/// called with the cluster's index in `clusters`. Each tick runs in two halves, the first of
/// every cluster before the second of any ([`Cluster::begin_lockstep`],
/// [`Cluster::finish_lockstep`]), so that each has its neighbours' ops of the tick before
/// it steps.
pub fn lockstep_round(
    clusters: &mut [Cluster],
    timeout: Duration,
    mut user: impl FnMut(usize, &TickContext<'_>, &mut PhysicsHandle<'_>),
) -> Result<(), ClusterError> {
    for (index, cluster) in clusters.iter_mut().enumerate() {
        cluster.begin_lockstep(timeout, |context, physics| user(index, context, physics))?;
    }
    for cluster in clusters.iter_mut() {
        cluster.finish_lockstep(timeout)?;
    }
    Ok(())
}
