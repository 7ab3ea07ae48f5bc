//! One live pod per cluster (issue 37, item 2), with real pod processes on shared memory and on
//! a real Redis server:
//!
//! - a second pod of a cluster that runs refuses to start, naming the running one (its process
//!   id), and the running one carries on;
//! - a pod killed with SIGKILL is replaced: on shared memory at once (iceoryx2's dead-node
//!   cleanup frees its claim), on Redis once its lease lapsed;
//! - on Redis, a cluster whose lease lapsed while it did not tick and was taken over stops at
//!   its next tick with the error naming the new holder;
//! - a pod restarted with its own tick count is heard at once, and frames of the pod it
//!   replaced, published after it (ticks ahead of the new pod's), are refused as stale by
//!   their incarnation, counted, and change nothing.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use rustix::process::{Pid, Signal, kill_process};
use seam_proxy::{Cluster, ClusterConfig, ClusterError, NeighbourStatus, monotonic_ns};
use seam_sim::BodyRole;
use seam_sim::wire::{ClusterId, ReplicationView};
use seam_tests::{TestContext, finish_pod, scene_path, start_pod};
use seam_transport::ClaimError;

const NODE: &str = env!("CARGO_BIN_EXE_seam-test-node");

seam_tests::backend_tests!(
    [shm: Shm, redis: Redis],
    [
        a_second_pod_of_a_running_cluster_refuses_to_start,
        a_killed_pod_is_replaced,
        frames_of_a_replaced_pod_are_refused_by_its_incarnation
    ]
);

seam_tests::backend_tests!(
    [redis_lease: Redis],
    [a_cluster_whose_lease_lapsed_and_was_taken_over_stops]
);

/// The test's transport URL; on Redis with a one-second lease (so a killed pod's lapses soon).
fn url(ctx: &TestContext) -> String {
    let url = ctx.url();
    if url.starts_with("redis") {
        format!("{url}?lease_ms=1000")
    } else {
        url
    }
}

/// A second `west` pod of the run, its stderr kept; waits for it to end.
fn second_pod(url: &str, run_id: &str) -> (std::process::ExitStatus, String, Duration) {
    let started = Instant::now();
    let out = Command::new(NODE)
        .arg(scene_path("crossfire.toml"))
        .args(["--cluster", "west", "--transport", url, "--run-id", run_id])
        .args(["--rate", "120", "--ticks", "120", "--quiet"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .expect("run a second pod");
    (
        out.status,
        String::from_utf8_lossy(&out.stderr).into_owned(),
        started.elapsed(),
    )
}

fn first_pod(url: &str, run_id: &str) -> Child {
    start_pod(
        NODE,
        &scene_path("crossfire.toml"),
        "west",
        url,
        run_id,
        monotonic_ns() + 300_000_000,
        &[],
    )
}

fn a_second_pod_of_a_running_cluster_refuses_to_start(ctx: &TestContext) {
    let url = url(ctx);
    let run_id = format!("dup{}", std::process::id());
    let first = first_pod(&url, &run_id);
    std::thread::sleep(Duration::from_millis(800));
    let (status, stderr, took) = second_pod(&url, &run_id);
    assert!(!status.success(), "the second pod refused to start");
    assert!(
        stderr.contains("runs already") && stderr.contains(&format!("pid {}", first.id())),
        "it says the cluster runs and names the running pod (pid {}): {stderr}",
        first.id()
    );
    assert!(
        took < Duration::from_secs(3),
        "refused within a lease: {took:?}"
    );
    // The first carries on to the end, alone.
    let (_, report) = finish_pod(first);
    assert_eq!(report.ticks, 480, "the running pod ran every tick");
    assert_eq!(report.cluster_stats.frames_replayed, 0);
}

fn a_killed_pod_is_replaced(ctx: &TestContext) {
    let url = url(ctx);
    let run_id = format!("kill{}", std::process::id());
    let mut first = first_pod(&url, &run_id);
    std::thread::sleep(Duration::from_millis(800));
    let pid = Pid::from_raw(first.id() as i32).expect("a pid");
    kill_process(pid, Signal::KILL).expect("kill");
    let _ = first.wait();
    let (status, stderr, took) = second_pod(&url, &run_id);
    assert!(
        status.success(),
        "a pod replacing a killed one starts and runs: {stderr}"
    );
    // 120 ticks at 120 Hz is a second; on Redis it first waits for the lease (1 s) to lapse.
    assert!(took < Duration::from_secs(6), "{took:?}");
}

fn a_cluster_whose_lease_lapsed_and_was_taken_over_stops(ctx: &TestContext) {
    let url = format!("{}?lease_ms=300", ctx.url());
    let id = ClusterId::random();
    let mut old = Cluster::new(ClusterConfig::new(id, Vec::new(), &url)).expect("old");
    old.tick(|_, _| {}).expect("old ticks");
    // Refused while the old one holds the lease and renews it (ticking meanwhile).
    let started = Instant::now();
    let second = {
        let url = url.clone();
        std::thread::spawn(move || {
            Cluster::new(ClusterConfig::new(id, Vec::new(), &url))
                .err()
                .map(|e| format!("{e:?}"))
        })
    };
    while !second.is_finished() {
        old.tick(|_, _| {}).expect("old ticks");
        std::thread::sleep(Duration::from_millis(10));
    }
    let refused = second.join().expect("the second cluster's thread");
    assert!(
        refused
            .as_deref()
            .is_some_and(|e| e.contains("AlreadyRunning") && e.contains("Held")),
        "a second cluster is refused while the first renews its lease: {refused:?}"
    );
    assert!(started.elapsed() < Duration::from_secs(5));
    // The old one stops ticking (stopped, stalled): its lease lapses and a new one takes over.
    let mut new = Cluster::new(ClusterConfig::new(id, Vec::new(), &url)).expect("taken over");
    new.tick(|_, _| {}).expect("the new one ticks");
    std::thread::sleep(Duration::from_millis(150));
    let stopped = old.tick(|_, _| {});
    match stopped {
        Err(ClusterError::AlreadyRunning {
            source: ClaimError::Lost { holder, .. },
            ..
        }) => assert!(
            holder.contains(&format!("pid {}", std::process::id())),
            "names the new holder: {holder}"
        ),
        other => panic!("the old cluster must stop: {other:?}"),
    }
    new.tick(|_, _| {}).expect("the new one ticks on");
}

/// `cluster`'s proxy (or body) of `entity`: its x.
fn x_of(cluster: &Cluster, entity: seam_sim::wire::EntityId) -> Option<f32> {
    cluster.sim().state(entity).map(|s| s.position[0])
}

/// `n` free-running ticks of west's pod, then east's, each round.
fn tick_pair(west: &mut Cluster, east: &mut Cluster, n: usize) {
    for _ in 0..n {
        west.tick(|_, _| {}).expect("west ticks");
        east.tick(|_, _| {}).expect("east ticks");
    }
}

fn frames_of_a_replaced_pod_are_refused_by_its_incarnation(ctx: &TestContext) {
    let url = url(ctx);
    let (west, east) = (ClusterId::random(), ClusterId::random());
    let config = |id, neighbour| {
        let mut config = ClusterConfig::new(id, vec![neighbour], &url);
        config.gravity = [0.0; 3];
        config
    };
    let mut spy = seam_transport::open(&url).expect("a spy on west's channel");
    spy.subscribe(&seam_proxy::replication(west))
        .expect("subscribe");
    let mut east_pod = Cluster::new(config(east, west)).expect("east");
    let mut old = Cluster::new(config(west, east)).expect("west's first pod");
    let ball = seam_tests::ball_at(-3.0, west);
    old.spawn_owned(&ball, BodyRole::Dynamic).expect("spawn");
    tick_pair(&mut old, &mut east_pod, 40);
    assert_eq!(
        x_of(&east_pod, ball.id),
        Some(-3.0),
        "east proxies the ball"
    );
    // What west's first pod published, as a pod that lost its claim but still publishes would.
    let mut sent: Vec<Vec<u8>> = Vec::new();
    while let Some(message) = spy.try_receive().expect("receive") {
        sent.push(message.payload.to_vec());
    }
    let old_incarnation = old.incarnation();
    drop(old);

    // West's new pod counts its own ticks from 0 and holds the ball elsewhere.
    let mut new = Cluster::new(config(west, east)).expect("west's new pod");
    assert!(
        new.incarnation() > old_incarnation,
        "a later pod has a later incarnation: {} after {old_incarnation}",
        new.incarnation()
    );
    let moved = ball.at([-6.0, 0.0, 0.0]);
    new.spawn_owned(&moved, BodyRole::Dynamic).expect("spawn");
    tick_pair(&mut new, &mut east_pod, 5);
    assert_eq!(
        x_of(&east_pod, ball.id),
        Some(-6.0),
        "the new pod is heard at once, its ticks behind its predecessor's"
    );
    assert_eq!(east_pod.stats().frames_replayed, 0);

    // The old pod's last frames, ahead of the new pod in ticks, arrive now.
    let stale: Vec<&Vec<u8>> = sent
        .iter()
        .filter(|bytes| ReplicationView::parse(bytes).is_ok_and(|v| v.tick() > 30))
        .collect();
    assert!(stale.len() >= 5, "{} frames of west's old pod", stale.len());
    for bytes in &stale {
        let view = ReplicationView::parse(bytes).expect("a frame");
        assert_eq!(view.incarnation(), old_incarnation);
        spy.publish(&seam_proxy::replication(west), bytes)
            .expect("publish");
    }
    std::thread::sleep(Duration::from_millis(100));
    tick_pair(&mut new, &mut east_pod, 5);
    let stats = east_pod.stats();
    assert_eq!(
        stats.frames_stale,
        stale.len() as u64,
        "every frame of the replaced pod is refused as stale: {stats:#}"
    );
    assert_eq!(stats.frames_replayed, 0, "{stats:#}");
    assert_eq!(x_of(&east_pod, ball.id), Some(-6.0), "and changes nothing");
    assert_eq!(
        east_pod.neighbour_status(west),
        Some(NeighbourStatus::Alive)
    );
}
