//! Redis outages: the Redis transport reconnects with back-off and renews its subscriptions
//! after the server restarts, counting what it dropped meanwhile; pods keep ticking through
//! it, take nobody for dead for it, and report the gap. Each test runs its own `redis-server`
//! (killed with SIGKILL and started again on the same port), never the shared one.

use std::time::{Duration, Instant};

use seam_proxy::monotonic_ns;
use seam_tests::{finish_pod, private_redis, scene_path, start_pod, until_received};

const NODE: &str = env!("CARGO_BIN_EXE_seam-test-node");

#[test]
fn the_redis_transport_reconnects_and_resubscribes() {
    let Some(mut server) = private_redis() else {
        return;
    };
    let mut a = seam_transport::open(&server.url()).expect("a");
    let mut b = seam_transport::open(&server.url()).expect("b");
    b.subscribe("seam_out:direct").expect("subscribe");
    b.psubscribe("seam_out:pat*").expect("psubscribe");
    until_received(
        a.as_mut(),
        b.as_mut(),
        "seam_out:direct",
        Duration::from_secs(5),
    );

    server.kill();
    // Publishing and receiving go on without errors; what is published is counted as dropped.
    let deadline = Instant::now() + Duration::from_secs(5);
    while a.is_connected() || b.is_connected() {
        assert!(Instant::now() < deadline, "the outage was not noticed");
        a.publish("seam_out:direct", b"during")
            .expect("publish while down");
        let _ = b
            .receive_timeout(Duration::from_millis(10))
            .expect("receive while down");
    }
    assert!(a.stats().dropped_while_down > 0, "{:?}", a.stats());

    server.restart().expect("restart redis-server");
    until_received(
        a.as_mut(),
        b.as_mut(),
        "seam_out:direct",
        Duration::from_secs(5),
    );
    until_received(
        a.as_mut(),
        b.as_mut(),
        "seam_out:pattern",
        Duration::from_secs(5),
    );
    for stats in [a.stats(), b.stats()] {
        assert_eq!((stats.disconnects, stats.reconnects), (1, 1), "{stats:?}");
        assert!(stats.down_ns > 0);
    }
    assert!(a.is_connected() && b.is_connected());
}

#[test]
fn without_reconnect_a_lost_server_is_an_error() {
    let Some(mut server) = private_redis() else {
        return;
    };
    let mut a = seam_transport::open(&format!("{}?reconnect=0", server.url())).expect("a");
    a.publish("seam_out:x", b"before").expect("publish");
    server.kill();
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        match a.publish("seam_out:x", b"after") {
            Err(e) => {
                let text = e.to_string();
                assert!(text.contains("127.0.0.1"), "names the server: {text}");
                break;
            }
            Ok(_) => assert!(Instant::now() < deadline, "no error after the server died"),
        }
    }
}

/// Two `crossfire` pods on a private Redis server; the server is killed for a second (longer
/// than the 30-tick neighbour timeout at 120 Hz) and started again. Both pods run every tick,
/// take nobody for dead, reconnect, report the gap, and end with every entity owned once.
#[test]
fn pods_ride_out_a_redis_restart() {
    let Some(mut server) = private_redis() else {
        return;
    };
    let scene = scene_path("crossfire.toml");
    let run_id = format!("outage{}", std::process::id());
    let url = server.url();
    let start_at = monotonic_ns() + 500_000_000;
    let west = start_pod(NODE, &scene, "west", &url, &run_id, start_at, &[]);
    let east = start_pod(NODE, &scene, "east", &url, &run_id, start_at, &[]);
    std::thread::sleep(Duration::from_millis(1200));
    server.kill();
    std::thread::sleep(Duration::from_secs(1));
    server.restart().expect("restart redis-server");
    let (_, west) = finish_pod(west);
    let (_, east) = finish_pod(east);
    for pod in [&west, &east] {
        assert_eq!(pod.ticks, 480, "{} ran every tick", pod.cluster);
        assert_eq!(
            pod.cluster_stats.neighbours_lost, 0,
            "{}: nobody taken for dead for an outage",
            pod.cluster
        );
        let t = &pod.transport_stats;
        assert_eq!(
            (t.disconnects, t.reconnects),
            (1, 1),
            "{}: {t:?}",
            pod.cluster
        );
        assert!(
            t.down_ns >= 900_000_000 && t.dropped_while_down > 0,
            "{}: the gap is reported: {t:?}",
            pod.cluster
        );
    }
    assert!(
        west.cluster_stats.frames_accepted > 0 && east.cluster_stats.frames_accepted > 0,
        "frames flow"
    );
    let scene = seam_bench::scene::load(&scene).expect("scene");
    let ownership = seam_bench::run::ownership::check(&scene, &run_id, &[west, east]);
    assert!(ownership.holds(), "{ownership:?}");
}
