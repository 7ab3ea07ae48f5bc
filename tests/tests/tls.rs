//! TLS between pods and Redis (`rediss://`, issue 39 item 5): a CA made by the test (with the
//! `openssl` command) signs a private redis-server's certificate; transports that trust that
//! CA (`tls_ca=`) exchange messages and two clusters run over TLS; a transport that trusts
//! another CA is refused at start, saying why; and the TLS port does not take plain RESP.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use seam_proxy::{Cluster, ClusterConfig, lockstep_round};
use seam_sim::BodyRole;
use seam_sim::wire::ClusterId;
use seam_tests::{PATIENCE, ball_at, receive};

/// Whether `program --version` runs; otherwise the test skips with a line saying so, or fails
/// under `SEAM_REQUIRE_REDIS=1`.
fn have(program: &str) -> bool {
    let found = Command::new(program)
        .arg("version")
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
    openssl(
        dir,
        &[
            "req",
            "-x509",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-days",
            "2",
            "-subj",
            &format!("/CN=seam test {name}"),
            "-keyout",
            &format!("{name}.key"),
            "-out",
            &format!("{name}.pem"),
        ],
    );
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
    let dir = std::env::temp_dir().join(format!("seam-tls-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    make_ca(&dir, "ca");
    make_ca(&dir, "other");
    openssl(
        &dir,
        &[
            "req",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-subj",
            "/CN=127.0.0.1",
            "-keyout",
            "server.key",
            "-out",
            "server.csr",
        ],
    );
    std::fs::write(
        dir.join("san"),
        "subjectAltName=IP:127.0.0.1,DNS:localhost\n",
    )
    .expect("san");
    openssl(
        &dir,
        &[
            "x509",
            "-req",
            "-in",
            "server.csr",
            "-CA",
            "ca.pem",
            "-CAkey",
            "ca.key",
            "-CAcreateserial",
            "-days",
            "2",
            "-extfile",
            "san",
            "-out",
            "server.pem",
        ],
    );
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
    let ca = dir.join("ca.pem");
    let url = format!("rediss://127.0.0.1:{port}?tls_ca={}", ca.display());
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut subscriber = loop {
        match seam_transport::open(&url) {
            Ok(t) => break t,
            Err(e) if Instant::now() < deadline => {
                let _ = e;
                std::thread::sleep(Duration::from_millis(50));
            }
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

    // Two clusters over TLS.
    let (west, east) = (ClusterId::random(), ClusterId::random());
    let mut clusters: Vec<Cluster> = [(west, east), (east, west)]
        .into_iter()
        .map(|(me, other)| {
            Cluster::new(ClusterConfig::new(me, vec![other], &url)).expect("cluster")
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

    // Another CA: refused at start, saying why.
    let other = format!(
        "rediss://127.0.0.1:{port}?tls_ca={}",
        dir.join("other.pem").display()
    );
    let error = seam_transport::open(&other)
        .err()
        .expect("a server the CA did not sign is refused")
        .to_string();
    assert!(error.to_lowercase().contains("certificate"), "{error}");
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
    drop(clusters);
    std::fs::remove_dir_all(&dir).expect("clean up");
}
