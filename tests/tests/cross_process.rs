//! shm and redis between two real processes: the test spawns `seam-test-peer`.

use std::time::Duration;

use iceoryx2::prelude::*;
use seam_tests::{PATIENCE, Peer, TestContext, receive};
use seam_transport::Backend;

const PEER: &str = env!("CARGO_BIN_EXE_seam-test-peer");

seam_tests::backend_tests!(
    [shm: Shm, redis: Redis],
    [echo_round_trips,
    publishers_in_two_processes]
);

fn echo_round_trips(ctx: &TestContext) {
    let mut transport = ctx.open();
    let (ping, pong) = (ctx.channel("ping"), ctx.channel("pong"));
    transport.subscribe(&pong).expect("subscribe");
    const ROUNDS: usize = 200;
    let peer = Peer::spawn(
        PEER,
        &["echo", &ctx.url(), &ping, &pong, &ROUNDS.to_string()],
    );
    for round in 0..ROUNDS {
        let size = [0, 1, 64, 1000, 4096, 65_536][round % 6];
        let payload: Vec<u8> = (0..size).map(|i| (i + round) as u8).collect();
        assert_eq!(transport.publish(&ping, &payload).expect("publish"), 1);
        let echo = receive(transport.as_mut(), PATIENCE).expect("the echo comes back");
        assert!(
            echo.payload == payload,
            "round {round}: echo of {size} bytes intact"
        );
        assert_eq!(echo.channel, pong);
    }
    peer.finish();
    assert_eq!(transport.stats().overflow_drops, 0);
    assert_eq!(transport.stats().malformed_drops, 0);
}

fn publishers_in_two_processes(ctx: &TestContext) {
    let mut transport = ctx.open_with("buffer=1024");
    let channel = ctx.channel("fan_in");
    transport.subscribe(&channel).expect("subscribe");
    const COUNT: u64 = 500;
    let url = ctx.url_with("buffer=1024");
    let peers: Vec<Peer> = (0..2)
        .map(|_| Peer::spawn(PEER, &["publish", &url, &channel, &COUNT.to_string()]))
        .collect();
    let mut peers: Vec<Peer> = peers
        .into_iter()
        .map(|mut p| {
            p.expect_line("done");
            p
        })
        .collect();
    // Both publishers are done; every message is queued here. Split them by publisher: each
    // publisher's numbers must come in order, and none may be missing.
    let mut streams: Vec<Vec<u64>> = Vec::new();
    let mut last_value_of_stream = Vec::<u64>::new();
    for _ in 0..2 * COUNT {
        let message = receive(transport.as_mut(), PATIENCE).expect("arrives");
        let value = u64::from_le_bytes(message.payload.try_into().expect("8 bytes"));
        match last_value_of_stream
            .iter()
            .position(|last| *last + 1 == value)
        {
            Some(s) if value != 0 => {
                streams[s].push(value);
                last_value_of_stream[s] = value;
            }
            _ => {
                assert_eq!(value, 0, "a new publisher starts at 0, got {value}");
                streams.push(vec![value]);
                last_value_of_stream.push(value);
            }
        }
    }
    assert_eq!(streams.len(), 2);
    assert!(streams.iter().all(|s| s.len() as u64 == COUNT));
    for peer in peers.drain(..) {
        peer.finish();
    }
}

/// A pod killed with SIGKILL leaves its iceoryx2 node behind; the next transport to open
/// reclaims it, freeing the publisher slot the dead pod held.
#[test]
fn shm_reclaims_a_killed_pods_resources() {
    let Some(ctx) = TestContext::new(Backend::Shm) else {
        return;
    };
    let settings = "max_publishers=1";
    let channel = ctx.channel("one_publisher");
    let mut subscriber = ctx.open_with(settings);
    subscriber.subscribe(&channel).expect("subscribe");
    let peer = Peer::spawn(PEER, &["publish", &ctx.url_with(settings), &channel, "1"]);
    let mut peer = peer;
    peer.expect_line("done");
    let pid = peer.id();
    peer.kill();

    let mut config = iceoryx2::config::Config::default();
    let prefix = ctx.prefix().expect("shm has a prefix");
    config.global.prefix = FileName::new(prefix.as_bytes()).expect("prefix");
    let dead_nodes = || {
        let mut dead = 0;
        Node::<ipc::Service>::list(&config, |state| {
            if matches!(state, NodeState::Dead(_)) {
                dead += 1;
            }
            CallbackProgression::Continue
        })
        .expect("list nodes");
        dead
    };
    assert_eq!(dead_nodes(), 1, "the killed pod {pid} left its node behind");

    // Opening a transport reclaims the dead node and its publisher slot.
    let mut publisher = ctx.open_with(settings);
    assert_eq!(
        dead_nodes(),
        0,
        "opening a transport cleaned up the dead node"
    );
    assert_eq!(
        publisher
            .publish(&channel, b"alive")
            .expect("the slot is free again"),
        1
    );
    let message = receive(subscriber.as_mut(), Duration::from_secs(5)).expect("arrives");
    assert_eq!(message.payload, b"alive");
}
