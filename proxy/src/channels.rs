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

/// The name a cluster claims on its transport so that it runs once (see
/// `seam_transport::Transport::claim`; not a channel).
pub(crate) fn claim(cluster: ClusterId) -> String {
    format!("cluster:{cluster}")
}

/// Who claims a name (see [`claim`]): this process, its host and the time, for a second pod
/// of the cluster to name.
pub(crate) fn claimant() -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_owned())
        .unwrap_or_else(|_| "this host".to_owned());
    let since = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    format!(
        "pid {} on {host}, started at unix time {since}",
        std::process::id()
    )
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
