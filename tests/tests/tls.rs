//! TLS between pods and Redis (`rediss://`, `rediss-cluster://`; issue 39 item 5): a CA made by
//! the test (with the `openssl` command) signs the certificate of a private redis-server and of
//! a private Redis Cluster (tools/redis-cluster up --tls); transports that trust that CA
//! (`tls_ca=`) exchange messages and two clusters run over TLS; a transport that trusts another
//! CA is refused at start, saying why; and the TLS port does not take plain RESP.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use seam_proxy::{Cluster, ClusterConfig, lockstep_round};
use seam_sim::BodyRole;
use seam_sim::wire::ClusterId;
use seam_tests::{PATIENCE, ball_at, receive};

/// Whether `program` can be started; otherwise the test skips with a line saying so, or fails
/// under `SEAM_REQUIRE_REDIS=1`.
fn have(program: &str) -> bool {
    let found = Command::new(program)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok();
    if !found {
        if std::env::var("SEAM_REQUIRE_REDIS").as_deref() == Ok("1") {
            panic!("SEAM_REQUIRE_REDIS=1 but `{program}` is not installed");
        }
        eprintln!("SKIP: no `{program}`; set SEAM_REQUIRE_REDIS=1 to fail instead");
    }
    found
}

fn openssl(dir: &Path, args: &[&str]) {
    let status = Command::new("openssl")
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .expect("openssl runs");
    assert!(status.success(), "openssl {args:?}");
}

/// A CA (`NAME.pem`, `NAME.key`) in `dir`.
fn make_ca(dir: &Path, name: &str) {
    let subject = format!("/CN=seam test {name}");
    let (key, pem) = (format!("{name}.key"), format!("{name}.pem"));
    let args = [
        "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2",
    ];
    let mut args: Vec<&str> = args.to_vec();
    args.extend(["-subj", &subject, "-keyout", &key, "-out", &pem]);
    openssl(dir, &args);
}

/// In a fresh directory: a CA (`ca.pem`), a server certificate it signed for 127.0.0.1
/// (`server.pem`, `server.key`), and another CA (`other.pem`).
fn certificates(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("seam-tls-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    make_ca(&dir, "ca");
    make_ca(&dir, "other");
    let request = [
        "req",
        "-newkey",
        "rsa:2048",
        "-nodes",
        "-subj",
        "/CN=127.0.0.1",
    ];
    let mut args: Vec<&str> = request.to_vec();
    args.extend(["-keyout", "server.key", "-out", "server.csr"]);
    openssl(&dir, &args);
    std::fs::write(dir.join("san"), "subjectAltName=IP:127.0.0.1\n").expect("san");
    let sign = [
        "x509",
        "-req",
        "-in",
        "server.csr",
        "-CA",
        "ca.pem",
        "-CAkey",
        "ca.key",
    ];
    let mut args: Vec<&str> = sign.to_vec();
    args.extend([
        "-CAcreateserial",
        "-days",
        "2",
        "-extfile",
        "san",
        "-out",
        "server.pem",
    ]);
    openssl(&dir, &args);
    dir
}

/// Two clusters, west and east, on `url`, a few lock-step rounds: west holds east's ball.
fn two_clusters_cross(url: &str) {
    let (west, east) = (ClusterId::random(), ClusterId::random());
    let mut clusters: Vec<Cluster> = [(west, east), (east, west)]
        .into_iter()
        .map(|(me, other)| {
            Cluster::new(ClusterConfig::new(me, vec![other], url)).expect("a cluster over TLS")
        })
        .collect();
    let ball = ball_at(2.0, east);
    clusters[1]
        .spawn_owned(&ball, BodyRole::Dynamic)
        .expect("east's ball");
    for _ in 0..5 {
        lockstep_round(&mut clusters, Duration::from_secs(10), |_, _, _| ())
            .expect("rounds over TLS");
    }
    assert!(
        clusters[0].sim().contains(ball.id),
        "west holds east's ball, over TLS"
    );
}

/// A transport on `url` with the CA `other.pem` of `dir` instead: refused, naming the
/// certificate.
fn another_ca_is_refused(url: &str, dir: &Path) {
    let other = url.replace(
        &dir.join("ca.pem").display().to_string(),
        &dir.join("other.pem").display().to_string(),
    );
    assert_ne!(other, url);
    let error = seam_transport::open(&other)
        .err()
        .expect("a server the trusted CA did not sign is refused")
        .to_string();
    assert!(error.to_lowercase().contains("certificate"), "{error}");
}

/// A redis-server child serving TLS only; killed when dropped.
struct TlsServer(std::process::Child);

impl Drop for TlsServer {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn pods_reach_redis_over_tls_with_the_tests_own_ca() {
    if !have("redis-server") || !have("openssl") {
        return;
    }
    let dir = certificates("server");
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
        .to_string();
    let _server = TlsServer(
        Command::new("redis-server")
            .args(["--port", "0", "--tls-port", &port, "--bind", "127.0.0.1"])
            .args([
                "--tls-cert-file",
                "server.pem",
                "--tls-key-file",
                "server.key",
            ])
            .args(["--tls-ca-cert-file", "ca.pem", "--tls-auth-clients", "no"])
            .args(["--save", "", "--appendonly", "no"])
            .current_dir(&dir)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("redis-server starts"),
    );
    let url = format!(
        "rediss://127.0.0.1:{port}?tls_ca={}",
        dir.join("ca.pem").display()
    );
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut subscriber = loop {
        match seam_transport::open(&url) {
            Ok(t) => break t,
            Err(_) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(50)),
            Err(e) => panic!("no TLS server at {url}: {e}"),
        }
    };
    let channel = format!("tls_round_trip_{}", std::process::id());
    subscriber.subscribe(&channel).expect("subscribe over TLS");
    let mut publisher = seam_transport::open(&url).expect("a second TLS transport");
    assert_eq!(
        publisher.publish(&channel, b"over tls").expect("publish"),
        1
    );
    let message = receive(subscriber.as_mut(), PATIENCE).expect("arrives over TLS");
    assert_eq!(message.payload, b"over tls");
    // Large enough to span many TLS records.
    let big = vec![7u8; 300_000];
    publisher.publish(&channel, &big).expect("publish");
    let message = receive(subscriber.as_mut(), PATIENCE).expect("a large one arrives");
    assert_eq!(message.payload, big);
    two_clusters_cross(&url);
    another_ca_is_refused(&url, &dir);
    // Plain RESP on the TLS port is no connection.
    let plain = format!("redis://127.0.0.1:{port}?timeout_ms=2000");
    assert!(
        seam_transport::open(&plain).is_err(),
        "plain RESP on the TLS port"
    );
    // A CA file that is not one.
    let bad = format!(
        "rediss://127.0.0.1:{port}?tls_ca={}",
        dir.join("san").display()
    );
    let error = seam_transport::open(&bad)
        .err()
        .expect("refused")
        .to_string();
    assert!(error.contains("tls_ca"), "{error}");
    std::fs::remove_dir_all(&dir).expect("clean up");
}

/// A Redis Cluster serving TLS only: channels of every shard cross, two clusters run on it,
/// and a transport trusting another CA is refused at start.
#[test]
fn pods_reach_a_redis_cluster_over_tls() {
    if !have("redis-server") || !have("redis-cli") || !have("openssl") {
        return;
    }
    let dir = certificates("cluster");
    let cluster = seam_bench::redis_cluster::RedisCluster::start_tls(&dir)
        .unwrap_or_else(|e| panic!("a TLS Redis Cluster: {e}"));
    let url = cluster.url().to_owned();
    assert!(url.starts_with("rediss-cluster://"), "{url}");
    let mut subscriber = seam_transport::open(&url).expect("the cluster over TLS");
    let mut publisher = seam_transport::open(&url).expect("a second transport");
    // Hash tags spread over the slots, so over the three shards.
    let channels: Vec<String> = (0..6).map(|i| format!("tls_shard:{{{i}}}")).collect();
    for channel in &channels {
        subscriber.subscribe(channel).expect("subscribe over TLS");
    }
    for channel in &channels {
        publisher
            .publish(channel, channel.as_bytes())
            .expect("publish");
    }
    let mut got: Vec<Vec<u8>> = (0..channels.len())
        .map(|_| {
            receive(subscriber.as_mut(), PATIENCE)
                .expect("arrives")
                .payload
        })
        .collect();
    got.sort();
    let mut sent: Vec<Vec<u8>> = channels.iter().map(|c| c.as_bytes().to_vec()).collect();
    sent.sort();
    assert_eq!(got, sent, "one message on each channel, every shard");
    two_clusters_cross(&url);
    another_ca_is_refused(&url, &dir);
    drop(cluster);
    std::fs::remove_dir_all(&dir).expect("clean up");
}
