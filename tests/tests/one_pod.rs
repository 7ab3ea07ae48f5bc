//! One live pod per cluster (issue 37, item 2), with real pod processes on shared memory and on
//! a real Redis server:
//!
//! - a second pod of a cluster that runs refuses to start, naming the running one (its process
//!   id), and the running one carries on;
//! - a pod killed with SIGKILL is replaced: on shared memory at once (iceoryx2's dead-node
//!   cleanup frees its claim), on Redis once its lease lapsed;
//! - on Redis, a cluster whose lease lapsed while it did not tick and was taken over stops at
//!   its next tick with the error naming the new holder.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use rustix::process::{Pid, Signal, kill_process};
use seam_proxy::{Cluster, ClusterConfig, ClusterError, monotonic_ns};
use seam_sim::wire::ClusterId;
use seam_tests::{TestContext, finish_pod, scene_path, start_pod};
use seam_transport::ClaimError;

const NODE: &str = env!("CARGO_BIN_EXE_seam-test-node");

seam_tests::backend_tests!(
    [shm: Shm, redis: Redis],
    [
        a_second_pod_of_a_running_cluster_refuses_to_start,
        a_killed_pod_is_replaced
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
