//! Channel names of the seam protocol.

use seam_sim::wire::ClusterId;

const REPLICATION: &str = "replication:";
const PHYSICS_EVENTS: &str = "physics_events:";

/// The channel a cluster publishes its entities' states on.
pub fn replication(cluster: ClusterId) -> String {
    format!("{REPLICATION}{cluster}")
}

/// The channel a cluster receives routed ops and contact reports on.
pub fn physics_events(cluster: ClusterId) -> String {
    format!("{PHYSICS_EVENTS}{cluster}")
}

/// What a received channel name says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Channel {
    Replication(ClusterId),
    PhysicsEvents(ClusterId),
}

/// Parses a channel name of the seam protocol.
pub(crate) fn parse(name: &str) -> Option<Channel> {
    let id = |rest: &str| rest.parse().ok().map(ClusterId);
    if let Some(rest) = name.strip_prefix(REPLICATION) {
        id(rest).map(Channel::Replication)
    } else if let Some(rest) = name.strip_prefix(PHYSICS_EVENTS) {
        id(rest).map(Channel::PhysicsEvents)
    } else {
        None
    }
}
