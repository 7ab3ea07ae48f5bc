//! seam-tests — conformance, acceptance, stability and fault tests of seam.
//!
//! # Layout
//!
//! - this file — [`TestContext`]: a per-test isolated transport URL (a unique iceoryx2 prefix on
//!   shared memory, unique channel names everywhere) and the Redis policy below.
//! - `src/bin/peer.rs` — `seam-test-peer`, the child process that cross-process tests spawn.
//! - `src/bin/node.rs` — `seam-test-node`, which is `seam node`, for the pod tests.
//! - `tests/conformance.rs` — the transport contract, written once and run on shm, local, redis
//!   and a Redis Cluster.
//! - `tests/redis_cluster.rs` — a Redis Cluster changed under the transport: a slot moved, a
//!   primary killed; no cluster to use.
//! - `tests/cross_process.rs` — shm and redis between two real processes.
//! - `tests/alloc_free.rs` — the steady-state shm path adds no allocation to iceoryx2's own.
//! - `tests/errors.rs` — errors that name what is wrong; passwords never shown.
//! - `tests/access.rs` — a pod's shared memory and files are its user's only.
//! - `tests/signing.rs` — a pod holding one cluster's signing key cannot speak for another.
//! - `tests/acl.rs` — one Redis ACL user per cluster: the server refuses another's channels.
//! - `tests/tls.rs` — `rediss://` to a server whose certificate the test's own CA signed.
//! - `tests/acceptance.rs` — the three layers end to end on every transport.
//! - `tests/contacts.rs` — contacts across the seam against one world.
//! - `tests/corner_contacts.rs` — one block at a corner of four clusters hit three ways, against
//!   one world's insertion-order floor and for momentum.
//! - `tests/bodies.rs` — catalog shapes, materials, groups and sensors across the seam.
//! - `tests/keyframes.rs` — delta frames against full frames, with frames dropped.
//! - `tests/seams.rs` — every bundled scene split with default settings against one world.
//! - `tests/stability.rs` — where each method breaks, pinned on both sides.
//! - `tests/handoff.rs` — a hand-off survives a lost frame, a stale repeat changes nothing.
//! - `tests/one_pod.rs` — a second pod of a running cluster refused, a killed one replaced, a
//!   pod whose lease lapsed and was taken over stopped.
//! - `tests/safe_handoffs.rs` — no body handed to a neighbour never heard, one not taken comes
//!   back, one owner for every body at every tick.
//! - `tests/logs.rs` — a returned hand-off, a dropped op and a refused frame logged by name.
//! - `tests/pushes.rs` — a routed push on a body in flight lands as in one world.
//! - `tests/delivery.rs` — no routed write or contact report lost or applied twice.
//! - `tests/garbage.rs` — untrusted input on a live cluster's channels, counted by kind.
//! - `tests/liveness.rs` — neighbours taken for dead, killed and stopped pods, rejoining.
//! - `tests/adoption.rs` — a dead cluster's entities adopted once each, and returned.
//! - `tests/outage.rs` — Redis killed and restarted under the transport and under pods.
//! - `tests/hosts.rs` — pods on simulated hosts with a bridge each.
//! - `tests/pods.rs` — the main job end to end, over shm and Redis.
//! - `tests/chaos.rs` — `seam chaos` end to end, short.
//! - `tests/capacity.rs` — `seam capacity` finds a size, and its table agrees with itself.
//! - `tests/throughput.rs` — `seam throughput` carries a small load on a server and a cluster.
//! - `tests/inspector.rs` — a recorded run's page in headless Chromium.
//! - `tests/fuzz_corpus.rs` — every input kept for the fuzz targets, replayed.
//! - `tests/shape.rs` — no import circle; files and functions within their bounds; every
//!   crate's layout listing its modules, and this list every test file.
//!
//! Redis tests talk to `SEAM_REDIS_URL` (default `redis://127.0.0.1:6379`). When no server answers
//! they print a skip notice and pass, unless `SEAM_REQUIRE_REDIS=1`, under which they fail.
//! Redis Cluster tests use `SEAM_REDIS_CLUSTER_URL`, or else a cluster each test process makes
//! with `tools/redis-cluster` (so `redis-server` and `redis-cli` must be installed), under the
//! same skip rule.

use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use seam_transport::{Backend, OwnedMessage, Transport};

/// Writes each listed test function once per backend: `backend_tests!([shm: Shm, redis: Redis],
/// [round_trip, …])` makes `shm::round_trip` and `redis::round_trip`, each calling
/// `round_trip(&TestContext)` (a test the context says to skip returns at once).
#[macro_export]
macro_rules! backend_tests {
    ([$($module:ident: $backend:ident),+ $(,)?], $tests:tt) => {
        $( $crate::backend_tests!(@module $module $backend $tests); )+
    };
    (@module $module:ident $backend:ident [$($test:ident),+ $(,)?]) => {
        mod $module {
            $(
                #[test]
                fn $test() {
                    if let Some(ctx) =
                        $crate::TestContext::new(::seam_transport::Backend::$backend)
                    {
                        super::$test(&ctx)
                    }
                }
            )+
        }
    };
}

/// A host clock a test drives by hand, for `Cluster::tick_at`: liveness counts silence in
/// ticks and in host time, and this lets a test pass host time without sleeping.
#[derive(Debug, Clone, Copy)]
pub struct HandClock {
    now_ns: u64,
    dt_ns: u64,
}

impl HandClock {
    /// Starting at the host's monotonic time now, one step being `dt` seconds.
    pub fn new(dt: f32) -> Self {
        Self {
            now_ns: seam_proxy::monotonic_ns(),
            dt_ns: (f64::from(dt) * 1e9) as u64,
        }
    }

    /// The time now, ns.
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// Moves on by one step and returns the new time.
    pub fn advance(&mut self) -> u64 {
        self.now_ns += self.dt_ns;
        self.now_ns
    }
}

/// Where Redis tests connect unless `SEAM_REDIS_URL` says otherwise.
pub const DEFAULT_REDIS_URL: &str = "redis://127.0.0.1:6379";

/// Everything one test needs to stay out of every other test's way.
pub struct TestContext {
    backend: Backend,
    id: String,
}

impl TestContext {
    /// A context for `backend`, or `None` (after printing why) when the test must be skipped:
    /// only Redis tests are ever skipped, and only without `SEAM_REQUIRE_REDIS=1`.
    pub fn new(backend: Backend) -> Option<Self> {
        static COUNTER: AtomicU32 = AtomicU32::new(0);
        let id = format!(
            "t{}x{}",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        );
        let context = Self { backend, id };
        if backend == Backend::RedisCluster
            && let Err(e) = redis_cluster_url()
        {
            if std::env::var("SEAM_REQUIRE_REDIS").as_deref() == Ok("1") {
                panic!("SEAM_REQUIRE_REDIS=1 but no Redis Cluster is usable: {e}");
            }
            eprintln!("SKIP: no Redis Cluster ({e}); set SEAM_REQUIRE_REDIS=1 to fail instead");
            return None;
        }
        if backend == Backend::Redis
            && let Err(e) = seam_transport::open(&redis_url())
        {
            if std::env::var("SEAM_REQUIRE_REDIS").as_deref() == Ok("1") {
                panic!("SEAM_REQUIRE_REDIS=1 but Redis is not usable: {e}");
            }
            eprintln!(
                "SKIP: no Redis server answers ({e}); set SEAM_REQUIRE_REDIS=1 to fail instead"
            );
            return None;
        }
        Some(context)
    }

    /// The backend under test.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// The URL of an isolated transport, with extra `key=value` settings for iceoryx2 backends
    /// (Redis ignores them: its limits are the server's).
    pub fn url_with(&self, settings: &str) -> String {
        match self.backend {
            Backend::Redis => redis_url(),
            Backend::RedisCluster => redis_cluster_url().expect("checked by TestContext::new"),
            backend => {
                let mut url = format!("{}?prefix=seam_{}_", backend.name(), self.id);
                debug_assert_eq!(self.prefix().as_deref(), url.split("prefix=").nth(1));
                if !settings.is_empty() {
                    url.push('&');
                    url.push_str(settings);
                }
                url
            }
        }
    }

    /// The URL of an isolated transport with default settings.
    pub fn url(&self) -> String {
        self.url_with("")
    }

    /// Opens a transport on this test's URL.
    pub fn open(&self) -> Box<dyn Transport> {
        self.open_with("")
    }

    /// Opens a transport with extra settings (see [`Self::url_with`]).
    pub fn open_with(&self, settings: &str) -> Box<dyn Transport> {
        let url = self.url_with(settings);
        seam_transport::open(&url).unwrap_or_else(|e| panic!("cannot open {url}: {e}"))
    }

    /// The iceoryx2 file prefix of this test's transports (`None` on Redis).
    pub fn prefix(&self) -> Option<String> {
        (!self.is_redis()).then(|| format!("seam_{}_", self.id))
    }

    /// Whether the backend is a Redis server or a Redis Cluster (limits are the server's).
    pub fn is_redis(&self) -> bool {
        matches!(self.backend, Backend::Redis | Backend::RedisCluster)
    }

    /// A channel name unique to this test.
    pub fn channel(&self, name: &str) -> String {
        format!("{}:{name}", self.id)
    }
}

/// The Redis URL tests use.
pub fn redis_url() -> String {
    std::env::var("SEAM_REDIS_URL").unwrap_or_else(|_| DEFAULT_REDIS_URL.to_owned())
}

/// The Redis Cluster URL tests use: `SEAM_REDIS_CLUSTER_URL`, or else a cluster of this test
/// process's own, made once with `tools/redis-cluster up` (three primaries, three replicas)
/// and taken down by that script when the process exits. `Err` says why there is none (no
/// `redis-server` on the PATH, say).
pub fn redis_cluster_url() -> Result<String, String> {
    static URL: std::sync::OnceLock<Result<String, String>> = std::sync::OnceLock::new();
    URL.get_or_init(|| match std::env::var("SEAM_REDIS_CLUSTER_URL") {
        Ok(url) => Ok(url),
        Err(_) => seam_bench::redis_cluster::RedisCluster::start_for_process()
            .map(|cluster| cluster.url().to_owned())
            .map_err(|e| e.to_string()),
    })
    .clone()
}

/// A private Redis Cluster for a test that changes it (kills a primary, moves a slot), or
/// `None` (with a skip notice) where none can be made, unless `SEAM_REQUIRE_REDIS=1`, under
/// which the test fails.
pub fn private_cluster() -> Option<seam_bench::redis_cluster::RedisCluster> {
    match seam_bench::redis_cluster::RedisCluster::start() {
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

/// Publishes on `channel` until `receiver` gets a message on it (after an outage or a change of
/// server both sides must find the server first); panics after `within`, with both sides'
/// counters.
pub fn until_received(
    publisher: &mut dyn Transport,
    receiver: &mut dyn Transport,
    channel: &str,
    within: Duration,
) {
    let deadline = std::time::Instant::now() + within;
    while std::time::Instant::now() < deadline {
        publisher.publish(channel, b"after").expect("publish");
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

/// Receives one message, waiting up to `timeout`; panics on a transport error.
pub fn receive(transport: &mut dyn Transport, timeout: Duration) -> Option<OwnedMessage> {
    transport
        .receive_timeout(timeout)
        .unwrap_or_else(|e| panic!("receive failed: {e}"))
        .map(|m| m.to_owned())
}

/// Publishes on `channel` until the publish reaches at least `receivers` subscribers (a pattern
/// subscriber on shm must first discover the channel), letting `receiver` run discovery between
/// tries. Returns the message the receiver got. Panics after `timeout`.
pub fn publish_until_received(
    publisher: &mut dyn Transport,
    receiver: &mut dyn Transport,
    channel: &str,
    payload: &[u8],
    timeout: Duration,
) -> OwnedMessage {
    let deadline = Instant::now() + timeout;
    while Instant::now() < deadline {
        let reached = publisher
            .publish(channel, payload)
            .unwrap_or_else(|e| panic!("publish failed: {e}"));
        let wait = if reached > 0 {
            PATIENCE
        } else {
            Duration::from_millis(20)
        };
        if let Some(message) = receive(receiver, wait) {
            return message;
        }
        assert!(
            reached == 0,
            "a publish reached a subscriber but nothing arrived in {wait:?}"
        );
    }
    panic!("nothing published on {channel} arrived within {timeout:?}");
}

/// How long a test waits for something that should arrive at once.
pub const PATIENCE: Duration = Duration::from_secs(5);
/// How long a test waits to be sure that something does not arrive.
pub const SILENCE: Duration = Duration::from_millis(200);

/// A `seam-test-peer` child process, killed if the test ends without closing it.
pub struct Peer {
    child: std::process::Child,
    stdout: std::io::BufReader<std::process::ChildStdout>,
}

impl Peer {
    /// Starts `seam-test-peer` with `args` and waits for its `ready` line.
    pub fn spawn(peer_binary: &str, args: &[&str]) -> Self {
        use std::process::{Command, Stdio};
        let mut child = Command::new(peer_binary)
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {peer_binary}: {e}"));
        let stdout = std::io::BufReader::new(child.stdout.take().expect("piped stdout"));
        let mut peer = Self { child, stdout };
        peer.expect_line("ready");
        peer
    }

    /// Reads the child's next line and checks it is `expected`.
    pub fn expect_line(&mut self, expected: &str) {
        use std::io::BufRead;
        let mut line = String::new();
        self.stdout.read_line(&mut line).expect("read from peer");
        assert_eq!(
            line.trim(),
            expected,
            "the peer said something else (see its stderr)"
        );
    }

    /// The child's process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// Tells the child to exit and checks it succeeded.
    pub fn finish(mut self) {
        use std::io::Write;
        if let Some(stdin) = self.child.stdin.as_mut() {
            let _ = stdin.write_all(b"bye\n");
        }
        let status = self.child.wait().expect("wait for peer");
        assert!(status.success(), "peer failed: {status}");
    }

    /// Kills the child with SIGKILL, as a crash would.
    pub fn kill(mut self) {
        self.child.kill().expect("kill peer");
        let _ = self.child.wait();
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A ball at rest at `x` on the x axis, 0.5 m radius, 100 kg/m³, owned by `owner`, with a fresh
/// entity id.
pub fn ball_at(x: f32, owner: seam_sim::wire::ClusterId) -> seam_sim::wire::EntityState {
    use seam_sim::wire::{BodySpec, EntityId, EntityState, Shape};
    EntityState::new(
        EntityId::random(),
        owner,
        BodySpec::new(Shape::ball(0.5)).density(100.0),
    )
    .at([x, 0.0, 0.0])
}

/// Clusters in a row along x, one per `(x0, x1)` span (y and z ±100 m), each the neighbour of
/// the next, on `url`: their configurations, each holding the whole world map, with zero
/// gravity and Rapier's defaults otherwise (a test sets what it needs).
pub fn row_configs(url: &str, spans: &[(f32, f32)]) -> Vec<seam_proxy::ClusterConfig> {
    use seam_proxy::{ClusterConfig, Region, WorldCluster};
    use seam_sim::wire::ClusterId;
    let ids: Vec<ClusterId> = spans.iter().map(|_| ClusterId::random()).collect();
    let adjacent = |i: usize| -> Vec<ClusterId> {
        [i.checked_sub(1), Some(i + 1).filter(|&j| j < ids.len())]
            .into_iter()
            .flatten()
            .map(|j| ids[j])
            .collect()
    };
    let world: Vec<WorldCluster> = spans
        .iter()
        .enumerate()
        .map(|(i, &(x0, x1))| WorldCluster {
            spread: 0.0,
            id: ids[i],
            region: Region {
                min: [x0, -100.0, -100.0],
                max: [x1, 100.0, 100.0],
            },
            neighbours: adjacent(i),
        })
        .collect();
    world
        .iter()
        .map(|mapped| {
            let mut config = ClusterConfig::new(mapped.id, mapped.neighbours.clone(), url);
            config.gravity = [0.0; 3];
            config.region = mapped.region;
            config.world = world.clone();
            config
        })
        .collect()
}

/// A private `redis-server` for a test that crashes and restarts it, or `None` (with a skip
/// notice) where none can start, unless `SEAM_REQUIRE_REDIS=1`, under which the test fails.
pub fn private_redis() -> Option<seam_bench::redis_server::RedisServer> {
    match seam_bench::redis_server::RedisServer::start() {
        Ok(server) => Some(server),
        Err(e) if std::env::var("SEAM_REQUIRE_REDIS").as_deref() == Ok("1") => {
            panic!("SEAM_REQUIRE_REDIS=1 but no private redis-server starts: {e}")
        }
        Err(e) => {
            eprintln!("SKIP: {e}; set SEAM_REQUIRE_REDIS=1 to fail instead");
            None
        }
    }
}

/// The scene file `name` of `bench/scenes`.
pub fn scene_path(name: &str) -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("../bench/scenes/{name}"))
}

/// Starts a `seam node` pod (the `seam-test-node` binary) of `scene` at 120 Hz for 480 ticks
/// with a 30-tick neighbour timeout, its tick 0 at `start_at` (CLOCK_MONOTONIC ns), and `extra`
/// flags.
pub fn start_pod(
    node_binary: &str,
    scene: &std::path::Path,
    cluster: &str,
    url: &str,
    run_id: &str,
    start_at: u64,
    extra: &[&str],
) -> std::process::Child {
    use std::process::{Command, Stdio};
    Command::new(node_binary)
        .arg(scene)
        .args(["--cluster", cluster, "--transport", url, "--run-id", run_id])
        .args(["--rate", "120", "--ticks", "480", "--quiet"])
        .args(["--neighbour-timeout-ticks", "30"])
        .args(["--start-at", &start_at.to_string()])
        .args(extra)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .spawn()
        .expect("start a pod")
}

/// Reads a pod's JSON lines to the end and checks it exited well: the most proxies it
/// reported, and its final report.
pub fn finish_pod(mut pod: std::process::Child) -> (usize, seam_bench::node::NodeReport) {
    use seam_bench::node::NodeLine;
    use std::io::BufRead;
    let stdout = pod.stdout.take().expect("the pod's stdout");
    let mut proxies_seen = 0;
    let mut report = None;
    for line in std::io::BufReader::new(stdout).lines() {
        match serde_json::from_str::<NodeLine>(&line.expect("a line")).expect("a node line") {
            NodeLine::Progress(p) => proxies_seen = proxies_seen.max(p.proxies),
            NodeLine::Report(r) => report = Some(*r),
        }
    }
    assert!(pod.wait().expect("the pod ends").success());
    (proxies_seen, report.expect("the pod reports"))
}
