//! One Redis ACL user per cluster (issue 39 item 5), on a private redis-server: with the rules
//! of `seam_proxy::redis_acl_rules`, two clusters run as before, while a pod logged in as
//! west's user is refused by the server itself when it publishes east's states or reads east's
//! inbox, and a pod that starts as east with west's user fails at start with a clear error.

use std::time::Duration;

use seam_proxy::{
    Cluster, ClusterConfig, lockstep_round, physics_events, redis_acl_rules, replication,
};
use seam_sim::BodyRole;
use seam_sim::wire::{ClusterId, EntityId};
use seam_tests::ball_at;

const TIMEOUT: Duration = Duration::from_secs(10);

#[test]
fn each_pods_redis_user_publishes_only_its_own_frames() {
    let Some(server) = seam_tests::private_redis() else {
        return;
    };
    let (west, east) = (ClusterId::random(), ClusterId::random());
    let client = redis::Client::open(server.url()).expect("url");
    let mut admin = client.get_connection().expect("connect");
    let user_url = |name: &str| {
        server
            .url()
            .replacen("redis://", &format!("redis://{name}:pw-{name}@"), 1)
    };
    for (name, me, other) in [("west", west, east), ("east", east, west)] {
        let mut command = redis::cmd("ACL");
        command.arg("SETUSER").arg(name);
        for rule in redis_acl_rules(me, &[other], &format!("pw-{name}")) {
            command.arg(rule);
        }
        let made: redis::RedisResult<()> = command.query(&mut admin);
        made.unwrap_or_else(|e| panic!("ACL SETUSER {name}: {e}"));
    }

    // Two pods, each logged in as its own cluster's user, run as before.
    let (mine, theirs) = (EntityId::random(), EntityId::random());
    let mut clusters: Vec<Cluster> = [("west", west, east), ("east", east, west)]
        .into_iter()
        .map(|(name, me, other)| {
            Cluster::new(ClusterConfig::new(me, vec![other], &user_url(name)))
                .unwrap_or_else(|e| panic!("{name}'s pod with its own user: {e}"))
        })
        .collect();
    for (index, (id, owner, x)) in [(mine, west, -2.0), (theirs, east, 2.0)]
        .into_iter()
        .enumerate()
    {
        let mut state = ball_at(x, owner);
        state.id = id;
        clusters[index]
            .spawn_owned(&state, BodyRole::Dynamic)
            .expect("ball");
    }
    for _ in 0..5 {
        lockstep_round(&mut clusters, TIMEOUT, |_, _, _| ()).expect("rounds under ACL users");
    }
    assert!(clusters[0].sim().contains(theirs), "west holds east's ball");
    assert!(clusters[1].sim().contains(mine), "east holds west's ball");

    // West's user, publishing as east or reading east's inbox: refused by the server.
    let mut rogue = seam_transport::open(&user_url("west")).expect("west's user logs in");
    let refused = rogue
        .publish(&replication(east), b"east's states, forged")
        .expect_err("west's user cannot publish east's states");
    let text = refused.to_string();
    assert!(
        text.to_uppercase().contains("NOPERM") && text.contains(&replication(east)),
        "a clear refusal naming the channel: {text}"
    );
    assert!(!text.contains("pw-west"), "no password in errors: {text}");
    let refused = rogue
        .subscribe(&physics_events(east))
        .expect_err("west's user cannot read east's inbox");
    assert!(
        refused.to_string().to_uppercase().contains("NOPERM"),
        "{refused}"
    );
    // What west's pod must do, it may.
    rogue
        .publish(&physics_events(east), b"an op for east")
        .expect("west writes to east's inbox");
    rogue
        .subscribe(&replication(east))
        .expect("west reads east's states");

    // A pod that starts as east with west's user fails at start, saying why.
    let error = Cluster::new(ClusterConfig::new(east, vec![west], &user_url("west")))
        .err()
        .expect("east with west's user is refused")
        .to_string();
    assert!(error.to_uppercase().contains("NOPERM"), "{error}");
    // A wrong password: a clear error at start, the password not in it.
    let wrong = server
        .url()
        .replacen("redis://", "redis://west:not-the-password@", 1);
    let error = seam_transport::open(&wrong)
        .err()
        .expect("a wrong password is refused")
        .to_string();
    assert!(!error.contains("not-the-password"), "{error}");
    assert!(
        error.to_lowercase().contains("auth") || error.contains("WRONGPASS"),
        "{error}"
    );
}
