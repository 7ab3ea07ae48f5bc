//! The Redis Cluster backend against a real cluster of its own (`tools/redis-cluster`: three
//! primaries, three replicas on loopback), changed under it: a slot of a live channel moved to
//! another primary, and the primary of a live channel killed until its replica takes over.
//! Both sides must follow (the publisher redirected, the subscriber subscribed again at the
//! new primary) and count it. Also what it says when there is no cluster to use. Without
//! `redis-server` these skip, or fail under `SEAM_REQUIRE_REDIS=1`.

use std::time::Duration;

use seam_tests::{private_cluster, until_received};
use seam_transport::{OpenError, Transport};

fn open(url: &str) -> Box<dyn Transport> {
    seam_transport::open(url).unwrap_or_else(|e| panic!("cannot open {url}: {e}"))
}

/// A slot with a live channel moves to another primary (the protocol `redis-cli --cluster
/// reshard` follows, for that one slot): the old primary drops the subscription, the
/// subscriber subscribes again at the new one, the publisher is redirected, and messages flow
/// again.
#[test]
fn a_moved_slot_is_followed_by_publisher_and_subscriber() {
    let Some(cluster) = private_cluster() else {
        return;
    };
    let channel = "replication:{moved-slot}";
    let (mut publisher, mut subscriber) = (open(cluster.url()), open(cluster.url()));
    subscriber.subscribe(channel).expect("subscribe");
    until_received(
        publisher.as_mut(),
        subscriber.as_mut(),
        channel,
        Duration::from_secs(5),
    );
    let slot = cluster.slot_of(channel).expect("slot");
    let (_, to) = cluster.move_slot(slot).expect("the slot moves");
    until_received(
        publisher.as_mut(),
        subscriber.as_mut(),
        channel,
        Duration::from_secs(10),
    );
    assert_eq!(
        cluster.primary_of(slot).expect("served").port,
        to,
        "the slot moved"
    );
    let (sent, got) = (publisher.stats(), subscriber.stats());
    assert!(
        sent.redirects >= 1,
        "the publisher was redirected: {sent:?}"
    );
    assert!(
        got.resubscribes >= 1,
        "the subscriber subscribed again at the new primary: {got:?}"
    );
}

/// The primary of a live channel is killed: its replica is promoted (about two seconds with
/// the script's 1 s node timeout), both sides find it from the slot map and the channel works
/// again; what was published meanwhile is dropped and counted, never an error.
#[test]
fn a_failover_is_followed() {
    let Some(cluster) = private_cluster() else {
        return;
    };
    let channel = "physics_events:{failover}";
    let (mut publisher, mut subscriber) = (open(cluster.url()), open(cluster.url()));
    subscriber.subscribe(channel).expect("subscribe");
    until_received(
        publisher.as_mut(),
        subscriber.as_mut(),
        channel,
        Duration::from_secs(5),
    );
    let slot = cluster.slot_of(channel).expect("slot");
    let primary = cluster.primary_of(slot).expect("served");
    let replica = cluster
        .nodes()
        .expect("nodes")
        .into_iter()
        .find(|n| n.replica_of.as_deref() == Some(primary.id.as_str()))
        .expect("its replica");
    cluster.kill_primary_of(slot).expect("killed");
    until_received(
        publisher.as_mut(),
        subscriber.as_mut(),
        channel,
        Duration::from_secs(20),
    );
    assert_eq!(
        cluster.primary_of(slot).expect("served").id,
        replica.id,
        "the replica serves the slot now"
    );
    let got = subscriber.stats();
    assert!(got.resubscribes >= 1, "{got:?}");
    assert!(
        got.disconnects >= 1,
        "the lost primary was counted: {got:?}"
    );
}

/// No cluster to use: a clear error at start, naming what was tried.
#[test]
fn no_cluster_is_a_clear_error_at_start() {
    // Nothing listens on port 1 of loopback.
    let error = seam_transport::open("redis-cluster://127.0.0.1:1")
        .err()
        .expect("nothing answers");
    assert!(
        matches!(error, OpenError::Unreachable { .. }) && error.to_string().contains("127.0.0.1:1"),
        "{error}"
    );
    let error = seam_transport::open("redis-cluster://127.0.0.1:7000/3")
        .err()
        .expect("no databases");
    assert!(error.to_string().contains("no /DB"), "{error}");
    // A server that is not in cluster mode.
    if let Some(server) = seam_tests::private_redis() {
        let url = server.url().replace("redis://", "redis-cluster://");
        let error = seam_transport::open(&url).err().expect("not a cluster");
        assert!(error.to_string().contains("CLUSTER SLOTS"), "{error}");
    }
}
