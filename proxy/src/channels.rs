//! Channel names of the seam protocol.

use seam_sim::wire::ClusterId;

const REPLICATION: &str = "replication:";
const PHYSICS_EVENTS: &str = "physics_events:";

/// The channel a cluster publishes its entities' states on: `replication:{ID}`. The braces are
/// a Redis Cluster hash tag: only the id is hashed to find the slot, so a cluster's channels
/// and its claim share one shard, and clusters spread over the shards.
pub fn replication(cluster: ClusterId) -> String {
    format!("{REPLICATION}{{{cluster}}}")
}

/// The channel a cluster receives routed ops and contact reports on: `physics_events:{ID}`.
pub fn physics_events(cluster: ClusterId) -> String {
    format!("{PHYSICS_EVENTS}{{{cluster}}}")
}

/// The name a cluster claims on its transport so that it runs once (see
/// `seam_transport::Transport::claim`; not a channel): `cluster:{ID}`.
pub(crate) fn claim(cluster: ClusterId) -> String {
    format!("cluster:{{{cluster}}}")
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
    let id = |rest: &str| {
        rest.strip_prefix('{')
            .and_then(|rest| rest.strip_suffix('}'))
            .and_then(|id| id.parse().ok())
            .map(ClusterId)
    };
    if let Some(rest) = name.strip_prefix(REPLICATION) {
        id(rest).map(Channel::Replication)
    } else if let Some(rest) = name.strip_prefix(PHYSICS_EVENTS) {
        id(rest).map(Channel::PhysicsEvents)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_names_carry_the_cluster_as_a_hash_tag_and_read_back() {
        let cluster = ClusterId::from_u128(0x0b1c);
        let replication = replication(cluster);
        assert_eq!(
            replication,
            "replication:{00000000-0000-0000-0000-000000000b1c}"
        );
        assert_eq!(parse(&replication), Some(Channel::Replication(cluster)));
        assert_eq!(
            parse(&physics_events(cluster)),
            Some(Channel::PhysicsEvents(cluster))
        );
        assert_eq!(
            parse("replication:00000000-0000-0000-0000-000000000b1c"),
            None
        );
        assert_eq!(parse("replication:{}"), None);
        assert!(seam_transport::validate_channel(&replication).is_ok());
    }
}
