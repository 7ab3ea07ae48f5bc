//! Each pod speaks only for itself (issue 39 item 5): with per-cluster signing keys and a
//! keyring, two clusters exchange frames as before, while a pod holding west's key cannot
//! publish as east (its frames are refused as from the wrong sender), a pod with no key is not
//! heard at all, and a cluster that is not a neighbour is refused even when it signs as itself.

use std::path::{Path, PathBuf};
use std::time::Duration;

use seam_proxy::{Cluster, ClusterConfig, lockstep_round, physics_events, replication};
use seam_sim::BodyRole;
use seam_sim::wire::{
    self, ClusterId, EntityId, PhysicsEventsFrame, PhysicsOp, ReplicationFrame, RoutedOp, Stage,
    StateEncoding,
};
use seam_tests::ball_at;
use seam_transport::signing::{Keyring, Signer};

const TIMEOUT: Duration = Duration::from_secs(10);

/// A key file for each of `clusters` and a keyring of the first `trusted` of them, in a fresh
/// directory.
fn keys(dir: &Path, clusters: &[ClusterId], trusted: usize) -> Vec<PathBuf> {
    std::fs::create_dir_all(dir).expect("key dir");
    let signers: Vec<Signer> = clusters
        .iter()
        .map(|c| Signer::generate(c.as_u128()).expect("random"))
        .collect();
    Keyring::of(&signers[..trusted])
        .write_file(&dir.join("keyring"))
        .expect("keyring");
    signers
        .iter()
        .enumerate()
        .map(|(i, signer)| {
            let path = dir.join(format!("{i}.key"));
            signer.write_file(&path).expect("key file");
            path
        })
        .collect()
}

fn op_frame(from: ClusterId, incarnation: u64, tick: u64, target: EntityId) -> PhysicsEventsFrame {
    let mut frame = PhysicsEventsFrame::empty(from, tick, Stage::AfterStep, 0);
    frame.incarnation = incarnation;
    frame.ops = vec![RoutedOp {
        op: PhysicsOp::SetLinvel {
            target,
            linvel: [50.0, 0.0, 0.0],
        },
        seq: 1,
        issuer: None,
        issued_ns: 0,
        issued_tick: tick,
        age_ticks: 0,
    }];
    frame
}

#[test]
fn a_pod_with_wests_key_cannot_speak_for_east() {
    let (west, east, north) = (
        ClusterId::random(),
        ClusterId::random(),
        ClusterId::random(),
    );
    let dir = std::env::temp_dir().join(format!("seam-signing-test-{}", std::process::id()));
    let files = keys(&dir, &[west, east, north], 3);
    let ring = dir.join("keyring");
    let base = format!("local?prefix=seam_signing_{}_", std::process::id());
    let signed = |key: &Path| {
        format!(
            "{base}&sign_key={}&keyring={}",
            key.display(),
            ring.display()
        )
    };
    let (mine, theirs) = (EntityId::random(), EntityId::random());
    let mut clusters: Vec<Cluster> = [(west, east, &files[0]), (east, west, &files[1])]
        .into_iter()
        .map(|(me, other, key)| {
            Cluster::new(ClusterConfig::new(me, vec![other], &signed(key))).expect("cluster")
        })
        .collect();
    let mut state = ball_at(-2.0, west);
    state.id = mine;
    clusters[0]
        .spawn_owned(&state, BodyRole::Dynamic)
        .expect("west's ball");
    let mut state = ball_at(2.0, east);
    state.id = theirs;
    clusters[1]
        .spawn_owned(&state, BodyRole::Dynamic)
        .expect("east's ball");
    for _ in 0..5 {
        lockstep_round(&mut clusters, TIMEOUT, |_, _, _| ()).expect("signed rounds");
    }
    let honest = clusters[0].stats();
    assert!(honest.frames_accepted >= 10, "{honest:?}");
    assert_eq!(honest.frames_wrong_sender, 0, "{honest:?}");
    assert!(clusters[0].sim().contains(theirs), "west holds east's ball");

    // A pod holding west's key, publishing as east: a replication frame with a body of its own
    // making on east's channel, and an op on west's ball in west's inbox, numbered and
    // incarnated as east's own (all of which the wire shows), so only the signature gives it
    // away.
    let tick = clusters[0].sim().tick();
    let incarnation = clusters[1].incarnation();
    let forged_body = EntityId::random();
    let mut forged_state = ball_at(1.0, east);
    forged_state.id = forged_body;
    let replication_frame = ReplicationFrame {
        incarnation,
        from: east,
        tick,
        states: vec![forged_state],
    };
    let as_east = [
        (
            replication(east),
            replication_frame
                .encode(StateEncoding::Exact)
                .expect("encodes"),
        ),
        (
            physics_events(west),
            wire::encode(&op_frame(east, incarnation, tick, mine)),
        ),
    ];
    let mut rogue = seam_transport::open(&format!("{base}&sign_key={}", files[0].display()))
        .expect("a pod with west's key");
    let mut keyless = seam_transport::open(&base).expect("a pod with no key");
    // North signs as itself and is trusted, but is not west's neighbour.
    let mut stranger =
        seam_transport::open(&format!("{base}&sign_key={}", files[2].display())).expect("north");
    for (channel, payload) in &as_east {
        rogue.publish(channel, payload).expect("publish");
        keyless.publish(channel, payload).expect("publish");
    }
    stranger
        .publish(
            &physics_events(west),
            &wire::encode(&op_frame(north, 0, tick, mine)),
        )
        .expect("publish");
    for _ in 0..5 {
        lockstep_round(&mut clusters, TIMEOUT, |_, _, _| ()).expect("rounds go on");
    }
    let after = clusters[0].stats();
    assert_eq!(
        after.frames_wrong_sender, 3,
        "both frames signed by west as east, and north's, refused: {after:?}"
    );
    assert_eq!(
        clusters[0].transport_stats().unsigned_drops,
        2,
        "the keyless pod's frames never reach the cluster"
    );
    assert!(
        !clusters[0].sim().contains(forged_body),
        "no body of the forger's making"
    );
    let v = clusters[0].sim().state(mine).expect("west's ball").linvel;
    assert!(
        v[0].abs() < 1.0,
        "no forged op applied to west's ball: {v:?}"
    );
    assert_eq!(after.ops_applied, 0, "{after:?}");
    assert_eq!(clusters[0].stats().frames_accepted, after.frames_accepted);
    drop(clusters);
    std::fs::remove_dir_all(&dir).expect("clean up");
}
