//! A Redis ACL user for one cluster's pod: what it may publish, subscribe to and claim, and
//! nothing else, so that with one user per cluster the server itself refuses a pod that
//! publishes another cluster's frames.
//!
//! Redis channel permissions (`&pattern`) do not tell publishing from subscribing, so the
//! rules use a Redis 7 selector: the user's root permissions allow the subscribe commands on
//! the channels the cluster reads (its neighbours' `replication`, its own `physics_events`),
//! and one selector allows the publish commands on the channels it writes (its own
//! `replication`, its neighbours' `physics_events`). A publish is allowed only if one of them
//! allows both the command and the channel, so west may read `replication:{east}` but not
//! write it. The claim that keeps one pod per cluster is a key of its own
//! (`seam:claim:cluster:{ID}`), read and written by three short scripts.

use seam_sim::wire::ClusterId;

use crate::channels::{claim, physics_events, replication};

/// The arguments of `ACL SETUSER USER ...` (after the user name) that make the user of
/// `cluster`'s pod, with `password`, able to run that cluster with `neighbours` and no more.
/// The user is reset first, so the rules are the whole of it.
pub fn redis_acl_rules(
    cluster: ClusterId,
    neighbours: &[ClusterId],
    password: &str,
) -> Vec<String> {
    let mut rules: Vec<String> = [
        "reset",
        "on",
        "resetchannels",
        "resetkeys",
        "-@all",
        // Logging in (redis-rs also tries CLIENT SETINFO, which Redis 7.0 does not know and
        // an ACL cannot name there; its refusal is ignored).
        "+auth",
        "+hello",
        "+ping",
        "+client|setname",
        // A Redis Cluster's slot map.
        "+cluster|slots",
        // Reading.
        "+subscribe",
        "+unsubscribe",
        "+ssubscribe",
        "+sunsubscribe",
        // The claim's scripts and what they call.
        "+eval",
        "+get",
        "+pttl",
        "+set",
        "+pexpire",
        "+del",
        "+time",
    ]
    .into_iter()
    .map(str::to_owned)
    .collect();
    rules.push(format!(">{password}"));
    rules.push(format!("~seam:claim:{}", claim(cluster)));
    rules.extend(neighbours.iter().map(|&n| format!("&{}", replication(n))));
    rules.push(format!("&{}", physics_events(cluster)));
    let mut writes = vec![
        "+publish".to_owned(),
        "+spublish".to_owned(),
        format!("&{}", replication(cluster)),
    ];
    writes.extend(
        neighbours
            .iter()
            .map(|&n| format!("&{}", physics_events(n))),
    );
    rules.push(format!("({})", writes.join(" ")));
    rules
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cluster_reads_its_neighbours_and_writes_its_own() {
        let (west, east) = (ClusterId::random(), ClusterId::random());
        let rules = redis_acl_rules(west, &[east], "pw").join(" ");
        assert!(rules.starts_with("reset on "), "{rules}");
        assert!(
            rules.contains(&format!("&{}", replication(east))),
            "{rules}"
        );
        assert!(
            rules.contains(&format!("&{}", physics_events(west))),
            "{rules}"
        );
        let selector = rules.split('(').nth(1).expect("a selector");
        assert!(selector.contains(&format!("&{}", replication(west))));
        assert!(selector.contains(&format!("&{}", physics_events(east))));
        assert!(!selector.contains(&replication(east)));
        assert!(rules.contains(&format!("~seam:claim:cluster:{{{west}}}")));
    }
}
