//! Peer liveness: a neighbour that stops publishing is taken for dead after a number of ticks,
//! its proxies despawned; when it publishes again it rejoins. In one process on the in-process
//! transport, and with real pods where one is killed with SIGKILL or stopped with SIGSTOP.

use std::process::Child;
use std::time::Duration;

use rustix::process::{Pid, Signal, kill_process};
use seam_bench::node::NodeReport;
use seam_proxy::{Cluster, ClusterConfig, NeighbourStatus, monotonic_ns};
use seam_sim::BodyRole;
use seam_sim::wire::ClusterId;
use seam_tests::{HandClock, TestContext, ball_at, finish_pod, scene_path, start_pod};
use seam_transport::Backend;

const TIMEOUT_TICKS: u64 = 10;

#[test]
fn a_silent_neighbour_is_dropped_and_rejoins() {
    let (a, b) = (ClusterId::random(), ClusterId::random());
    let url = format!("local?prefix=seam_live_{}_", std::process::id());
    let mut config_b = ClusterConfig::new(b, vec![a], &url);
    config_b.gravity = [0.0; 3];
    config_b.neighbour_timeout_ticks = TIMEOUT_TICKS;
    let mut config_a = ClusterConfig::new(a, vec![b], &url);
    config_a.gravity = [0.0; 3];
    let mut cluster_a = Cluster::new(config_a).expect("a");
    let mut cluster_b = Cluster::new(config_b).expect("b");
    for x in [1.0, 3.0] {
        cluster_a
            .spawn_owned(&ball_at(x, ClusterId::random()), BodyRole::Dynamic)
            .expect("spawn");
    }
    assert_eq!(
        cluster_b.neighbour_status(a),
        Some(NeighbourStatus::NotHeard)
    );
    for _ in 0..3 {
        cluster_a.tick(|_, _| {}).expect("a ticks");
        cluster_b.tick(|_, _| {}).expect("b ticks");
    }
    assert_eq!(cluster_b.sim().len(), 2, "B models A's two balls");
    assert_eq!(cluster_b.neighbour_status(a), Some(NeighbourStatus::Alive));

    // A stops. Silence counts in ticks and in host time: B catching up (ticks back to back,
    // its clock standing still) keeps A however many ticks it runs...
    let mut clock = HandClock::new(cluster_b.config().dt);
    for _ in 0..3 * TIMEOUT_TICKS {
        cluster_b
            .tick_at(clock.now_ns(), |_, _| {})
            .expect("b ticks");
    }
    assert_eq!(cluster_b.neighbour_status(a), Some(NeighbourStatus::Alive));
    assert_eq!(
        cluster_b.sim().len(),
        2,
        "catching up takes nobody for dead"
    );
    // ... and paced like a pod, one dt a tick, B keeps its proxies for the timeout after A's
    // last frame, then drops them.
    cluster_a.tick(|_, _| {}).expect("a ticks");
    cluster_b
        .tick_at(clock.now_ns(), |_, _| {})
        .expect("b ticks");
    for tick in 1..=TIMEOUT_TICKS + 1 {
        cluster_b
            .tick_at(clock.advance(), |_, _| {})
            .expect("b ticks");
        let expected = if tick <= TIMEOUT_TICKS { 2 } else { 0 };
        assert_eq!(cluster_b.sim().len(), expected, "silent for {tick} ticks");
    }
    assert_eq!(cluster_b.neighbour_status(a), Some(NeighbourStatus::Dead));
    assert_eq!(cluster_b.stats().neighbours_lost, 1);
    // Silence does not count twice, and nothing is handed to a neighbour taken for dead.
    cluster_b
        .tick_at(clock.advance(), |_, _| {})
        .expect("b ticks");
    assert_eq!(cluster_b.stats().neighbours_lost, 1);
    let own = ball_at(-2.0, ClusterId::random());
    cluster_b
        .spawn_owned(&own, BodyRole::Dynamic)
        .expect("spawn");
    let refused = cluster_b
        .transfer_authority(own.id, a)
        .expect_err("A is taken for dead");
    assert!(refused.to_string().contains("dead"), "{refused}");

    // A is back: its next frame brings its entities back as proxies.
    cluster_a.tick(|_, _| {}).expect("a ticks");
    cluster_b
        .tick_at(clock.advance(), |_, _| {})
        .expect("b ticks");
    assert_eq!(cluster_b.neighbour_status(a), Some(NeighbourStatus::Alive));
    assert_eq!(cluster_b.stats().neighbours_rejoined, 1);
    assert_eq!(
        cluster_b.sim().len(),
        3,
        "A's two balls are proxies again, beside B's own"
    );
    cluster_b
        .transfer_authority(own.id, a)
        .expect("A is alive again: hand-offs to it are allowed");
}

const NODE: &str = env!("CARGO_BIN_EXE_seam-test-node");

/// `crossfire`'s pods on a fresh shm prefix, tick 0 half a second from now.
struct Crossfire {
    ctx: TestContext,
    scene: std::path::PathBuf,
    run_id: String,
    start_at: u64,
}

impl Crossfire {
    fn new(tag: &str) -> Option<Self> {
        Some(Self {
            ctx: TestContext::new(Backend::Shm)?,
            scene: scene_path("crossfire.toml"),
            run_id: format!("{tag}{}", std::process::id()),
            start_at: monotonic_ns() + 500_000_000,
        })
    }

    /// Starts the pod of `cluster` with `extra` flags.
    fn pod(&self, cluster: &str, extra: &[&str]) -> Child {
        let url = self.ctx.url();
        start_pod(
            NODE,
            &self.scene,
            cluster,
            &url,
            &self.run_id,
            self.start_at,
            extra,
        )
    }

    /// Checks that every entity of the run ended with exactly one owner.
    fn assert_ownership(&self, reports: &[NodeReport]) {
        assert_ownership(&self.scene, &self.run_id, reports);
    }
}

/// Checks that every entity of the run ended with exactly one owner.
fn assert_ownership(scene: &std::path::Path, run_id: &str, reports: &[NodeReport]) {
    let scene = seam_bench::scene::load(scene).expect("scene");
    let ownership = seam_bench::run::ownership::check(&scene, run_id, reports);
    assert!(ownership.holds(), "{ownership:?}");
    assert!(ownership.expected >= scene.entity_count() as usize);
}

/// A pod stopped with SIGSTOP for a second costs counted drops, not blocked neighbours: west
/// keeps its schedule, takes east for dead and sees it rejoin; east's receive buffers overflow
/// (counted), and after SIGCONT it catches up and runs every tick.
#[test]
fn a_stopped_pod_costs_counted_drops_and_catches_up() {
    let Some(run) = Crossfire::new("stop") else {
        return;
    };
    let west = run.pod("west", &[]);
    let east = run.pod("east", &[]);
    std::thread::sleep(Duration::from_millis(1200));
    let signal = |child: &Child, signal: Signal| {
        let pid = Pid::from_raw(child.id() as i32).expect("a pid");
        kill_process(pid, signal).expect("signal");
    };
    signal(&east, Signal::STOP);
    std::thread::sleep(Duration::from_secs(1));
    signal(&east, Signal::CONT);
    let (_, west) = finish_pod(west);
    let (_, east) = finish_pod(east);
    eprintln!(
        "west {:?}\neast {:?}",
        west.cluster_stats, east.cluster_stats
    );
    assert_eq!((west.ticks, east.ticks), (480, 480), "both ran every tick");
    assert!(
        west.max_lag_ns < 250_000_000,
        "west kept its schedule: lag {} ms",
        west.max_lag_ns / 1_000_000
    );
    assert_eq!(
        west.cluster_stats.neighbours_lost, 1,
        "west took east for dead"
    );
    assert_eq!(
        west.cluster_stats.neighbours_rejoined, 1,
        "and saw it rejoin"
    );
    assert!(
        east.transport_stats.overflow_drops > 0,
        "east's full buffers dropped frames, counted: {:?}",
        east.transport_stats
    );
    assert!(
        east.max_lag_ns >= 900_000_000,
        "east was stopped for a second (lag {} ms)",
        east.max_lag_ns / 1_000_000
    );
    // West adopted east's entities while it took east for dead, and handed every one back when
    // east returned still claiming them: each entity has one owner.
    let adopted = west.cluster_stats.entities_adopted;
    assert!(adopted > 0, "west adopted east's entities");
    assert_eq!(west.cluster_stats.entities_returned, adopted);
    run.assert_ownership(&[west, east]);
}

/// Two `crossfire` pods over shared memory; east is killed with SIGKILL a second in. West keeps
/// ticking, takes east for dead after its timeout, adopts east's entities (no proxy of east
/// is left), and reports it.
#[test]
fn a_killed_pod_is_taken_for_dead_by_its_neighbour() {
    let Some(run) = Crossfire::new("live") else {
        return;
    };
    let west = run.pod("west", &[]);
    let mut east = run.pod("east", &[]);
    std::thread::sleep(Duration::from_millis(1500));
    east.kill().expect("SIGKILL east");
    east.wait().expect("east is gone");
    let (proxies_seen, report) = finish_pod(west);
    assert!(
        proxies_seen > 0,
        "west modelled east's crates while east lived"
    );
    assert_eq!(report.ticks, 480, "west kept ticking");
    assert_eq!(
        report.cluster_stats.neighbours_lost, 1,
        "east taken for dead"
    );
    assert_eq!(report.proxies, 0, "east's proxies became west's own");
    assert!(report.cluster_stats.entities_adopted > 0);
    run.assert_ownership(&[report]);
}

/// East is killed, and restarted with `--rejoin` two seconds later: west takes it for dead and
/// adopts its entities, the new east starts empty at the world's tick (its iceoryx2 node
/// reclaims what the dead one left), west sees it rejoin and models nothing twice; every entity
/// ends with one owner.
#[test]
fn a_killed_pod_restarts_and_rejoins() {
    let Some(run) = Crossfire::new("rejoin") else {
        return;
    };
    let west = run.pod("west", &[]);
    let mut east = run.pod("east", &[]);
    std::thread::sleep(Duration::from_millis(1200));
    east.kill().expect("SIGKILL east");
    east.wait().expect("east is gone");
    std::thread::sleep(Duration::from_millis(800));
    let east = run.pod("east", &["--rejoin"]);
    let (_, west) = finish_pod(west);
    let (_, east) = finish_pod(east);
    assert_eq!(west.ticks, 480);
    assert!(
        east.ticks < 400 && east.entities_at_start == 0,
        "east rejoined at the world's tick ({}), empty",
        east.ticks
    );
    assert_eq!(west.cluster_stats.neighbours_lost, 1);
    assert_eq!(west.cluster_stats.neighbours_rejoined, 1, "east rejoined");
    assert!(east.cluster_stats.frames_accepted > 0, "east hears west");
    let adopted = west.cluster_stats.entities_adopted;
    assert!(adopted > 0);
    assert_eq!(
        west.cluster_stats.entities_returned, adopted,
        "west handed east's entities back when it rejoined"
    );
    // East takes them all in (and the scene's own hand-off to it, if that came after).
    assert!(east.cluster_stats.handoffs_in >= adopted);
    run.assert_ownership(&[west, east]);
}
