//! The Redis Cluster backend against a real cluster of its own (`tools/redis-cluster`: three
//! primaries, three replicas on loopback), changed under it: a slot of a live channel moved to
//! another primary, and the primary of a live channel killed until its replica takes over.
//! Both sides must follow (the publisher redirected, the subscriber subscribed again at the
//! new primary) and count it. Also what it says when there is no cluster to use. Without
//! `redis-server` these skip, or fail under `SEAM_REQUIRE_REDIS=1`.

use std::process::Command;
use std::time::{Duration, Instant};

use seam_tests::PrivateCluster;
use seam_transport::{OpenError, Transport};

/// A private cluster, or `None` (after a skip line) where none starts.
fn cluster() -> Option<PrivateCluster> {
    match PrivateCluster::start() {
        Ok(cluster) => Some(cluster),
        Err(e) if std::env::var("SEAM_REQUIRE_REDIS").as_deref() == Ok("1") => {
            panic!("SEAM_REQUIRE_REDIS=1 but no Redis Cluster starts: {e}")
        }
        Err(e) => {
            eprintln!("SKIP: {e}; set SEAM_REQUIRE_REDIS=1 to fail instead");
            None
        }
    }
}

/// `redis-cli -p PORT ARGS...`'s output; panics if it fails.
fn cli(port: u16, args: &[&str]) -> String {
    let output = Command::new("redis-cli")
        .args(["-p", &port.to_string()])
        .args(args)
        .output()
        .expect("redis-cli runs");
    assert!(output.status.success(), "redis-cli {args:?} failed");
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// One line of `CLUSTER NODES`.
struct Node {
    id: String,
    port: u16,
    primary: bool,
    /// The primary it replicates, for a replica.
    of: String,
}

fn nodes(port: u16) -> Vec<Node> {
    cli(port, &["cluster", "nodes"])
        .lines()
        .filter_map(|line| {
            let words: Vec<&str> = line.split(' ').collect();
            let addr = words.get(1)?.split('@').next()?;
            Some(Node {
                id: words[0].to_owned(),
                port: addr.rsplit_once(':')?.1.parse().ok()?,
                primary: words.get(2)?.contains("master") && !words[2].contains("fail"),
                of: words.get(3)?.to_string(),
            })
        })
        .collect()
}

/// The slot of `channel`, as the cluster computes it.
fn slot(port: u16, channel: &str) -> u16 {
    cli(port, &["cluster", "keyslot", channel])
        .trim()
        .parse()
        .expect("a slot")
}

/// The node serving `slot` (from `CLUSTER SHARDS`-free parsing of `CLUSTER NODES` ranges).
fn serving(port: u16, slot: u16) -> Node {
    let text = cli(port, &["cluster", "nodes"]);
    for line in text.lines() {
        let words: Vec<&str> = line.split(' ').collect();
        let serves = words.iter().skip(8).any(|range| {
            let (a, b) = range.split_once('-').unwrap_or((range, range));
            matches!((a.parse::<u16>(), b.parse::<u16>()), (Ok(a), Ok(b)) if a <= slot && slot <= b)
        });
        if serves {
            let id = words[0];
            return nodes(port)
                .into_iter()
                .find(|n| n.id == id)
                .expect("listed");
        }
    }
    panic!("no node serves slot {slot}");
}

/// Publishes on `channel` until `receiver` gets a message on it; panics after `within`.
fn until_received(
    publisher: &mut dyn Transport,
    receiver: &mut dyn Transport,
    channel: &str,
    within: Duration,
) {
    let deadline = Instant::now() + within;
    while Instant::now() < deadline {
        publisher.publish(channel, b"x").expect("publish");
        if let Some(message) = receiver
            .receive_timeout(Duration::from_millis(50))
            .expect("receive")
            && message.channel == channel
        {
            return;
        }
    }
    panic!(
        "nothing on {channel} arrived within {within:?}; publisher {:?}, receiver {:?}",
        publisher.stats(),
        receiver.stats()
    );
}

fn open(url: &str) -> Box<dyn Transport> {
    seam_transport::open(url).unwrap_or_else(|e| panic!("cannot open {url}: {e}"))
}

/// A slot with a live channel moves to another primary (the protocol `redis-cli --cluster
/// reshard` follows, for that one slot): the old primary drops the subscription, the
/// subscriber subscribes again at the new one, the publisher is redirected, and messages flow
/// again.
#[test]
fn a_moved_slot_is_followed_by_publisher_and_subscriber() {
    let Some(cluster) = cluster() else {
        return;
    };
    let channel = "replication:{moved-slot}";
    let (mut publisher, mut subscriber) = (open(&cluster.url), open(&cluster.url));
    subscriber.subscribe(channel).expect("subscribe");
    until_received(
        publisher.as_mut(),
        subscriber.as_mut(),
        channel,
        Duration::from_secs(5),
    );
    let slot = slot(cluster.base, channel);
    let from = serving(cluster.base, slot);
    let to = nodes(cluster.base)
        .into_iter()
        .find(|n| n.primary && n.id != from.id)
        .expect("another primary");
    let slot_text = slot.to_string();
    cli(
        to.port,
        &["cluster", "setslot", &slot_text, "importing", &from.id],
    );
    cli(
        from.port,
        &["cluster", "setslot", &slot_text, "migrating", &to.id],
    );
    for port in [to.port, from.port] {
        cli(port, &["cluster", "setslot", &slot_text, "node", &to.id]);
    }
    until_received(
        publisher.as_mut(),
        subscriber.as_mut(),
        channel,
        Duration::from_secs(10),
    );
    assert_eq!(serving(to.port, slot).id, to.id, "the slot moved");
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
    let Some(cluster) = cluster() else {
        return;
    };
    let channel = "physics_events:{failover}";
    let (mut publisher, mut subscriber) = (open(&cluster.url), open(&cluster.url));
    subscriber.subscribe(channel).expect("subscribe");
    until_received(
        publisher.as_mut(),
        subscriber.as_mut(),
        channel,
        Duration::from_secs(5),
    );
    let slot = slot(cluster.base, channel);
    let primary = serving(cluster.base, slot);
    let replica = nodes(cluster.base)
        .into_iter()
        .find(|n| n.of == primary.id)
        .expect("its replica");
    let _ = Command::new("redis-cli")
        .args(["-p", &primary.port.to_string(), "shutdown", "nosave"])
        .output();
    until_received(
        publisher.as_mut(),
        subscriber.as_mut(),
        channel,
        Duration::from_secs(20),
    );
    assert_eq!(
        serving(replica.port, slot).id,
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
