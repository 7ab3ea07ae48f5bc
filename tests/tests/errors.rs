//! Errors that name what is wrong: bad URLs, unreachable servers, incompatible services, and
//! foreign bytes on a channel (counted and skipped, never handed to the caller).

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use seam_bench::run::{self, RunPlan};
use seam_tests::{PATIENCE, TestContext, receive, redis_url, scene_path};
use seam_transport::{Backend, OpenError, SubscribeError, Transport};

#[test]
fn bad_urls_say_what_is_wrong() {
    let error = |url: &str| match seam_transport::open(url) {
        Err(e) => e,
        Ok(_) => panic!("{url} opened"),
    };
    assert!(matches!(error("tcp://x"), OpenError::InvalidUrl { .. }));
    let unknown = error("shm?bufer=4").to_string();
    assert!(unknown.contains("unknown setting `bufer`"), "{unknown}");
    let zero = error("shm?buffer=0").to_string();
    assert!(zero.contains("positive"), "{zero}");
    let prefix = error("shm?prefix=a/b").to_string();
    assert!(prefix.contains("prefix"), "{prefix}");
    // Redis refuses unknown settings too, before connecting (nothing listens on port 1).
    let redis = error("redis://127.0.0.1:1?bogus=1").to_string();
    assert!(redis.contains("unknown setting `bogus`"), "{redis}");
    let lease = error("redis://127.0.0.1:1?lease_ms=0").to_string();
    assert!(lease.contains("lease_ms"), "{lease}");
}

/// Every configuration rule is checked when the cluster is made: the error names the field,
/// the value and the rule, and nothing is opened.
#[test]
fn a_bad_configuration_is_refused_at_construction() {
    use seam_proxy::{Cluster, ClusterConfig, ClusterError};
    use seam_sim::wire::ClusterId;
    let refused = |change: &dyn Fn(&mut ClusterConfig)| {
        let mut config = ClusterConfig::new(ClusterId::random(), vec![], "local?prefix=never_");
        change(&mut config);
        match Cluster::new(config) {
            Err(ClusterError::Config(e)) => e.to_string(),
            Err(other) => panic!("expected a configuration error, got {other}"),
            Ok(_) => panic!("accepted"),
        }
    };
    let dt = refused(&|c| c.dt = 0.0);
    assert!(dt.contains("`dt` = 0.0") && dt.contains("freezes"), "{dt}");
    let gravity = refused(&|c| c.gravity[1] = f32::NAN);
    assert!(gravity.contains("`gravity`"), "{gravity}");
    let own = refused(&|c| c.neighbours = vec![c.cluster_id]);
    assert!(own.contains("not its own neighbour"), "{own}");
    let interval = refused(&|c| c.replication_interval = 0);
    assert!(interval.contains("replication_interval"), "{interval}");
}

#[test]
fn unreachable_redis_names_the_address_and_hides_the_password() {
    // Port 1 on loopback: nothing listens there.
    let error = match seam_transport::open("redis://admin:hunter2@127.0.0.1:1") {
        Err(e) => e,
        Ok(_) => panic!("connected to port 1"),
    };
    let OpenError::Unreachable { addr, .. } = &error else {
        panic!("expected Unreachable, got {error:?}");
    };
    assert_eq!(addr, "127.0.0.1:1");
    for text in [error.to_string(), format!("{error:?}")] {
        assert!(text.contains("127.0.0.1:1"), "{text}");
        assert!(!text.contains("hunter2"), "the password leaked: {text}");
    }
}

#[test]
fn wrong_redis_password_is_an_authentication_error() {
    let Some(_ctx) = TestContext::new(Backend::Redis) else {
        return;
    };
    let url = redis_url().replacen("redis://", "redis://nobody:wrong-secret@", 1);
    match seam_transport::open(&url) {
        Err(error @ OpenError::AuthenticationFailed { .. }) => {
            for text in [error.to_string(), format!("{error:?}")] {
                assert!(
                    !text.contains("wrong-secret"),
                    "the password leaked: {text}"
                );
            }
        }
        Err(other) => panic!("expected AuthenticationFailed, got {other}"),
        Ok(_) => panic!("a wrong password was accepted"),
    }
}

#[test]
fn a_bad_url_hides_the_password() {
    for url in [
        "redis://admin:hunter2@127.0.0.1:notaport",
        "redis://admin:hunter2@",
        "redis://admin:hunter2@127.0.0.1:6379?bad=1",
    ] {
        let error = match seam_transport::open(url) {
            Err(e) => e,
            Ok(_) => panic!("{url} opened"),
        };
        for text in [error.to_string(), format!("{error:?}")] {
            assert!(
                !text.contains("hunter2"),
                "{url}: the password leaked: {text}"
            );
        }
    }
    assert_eq!(
        seam_transport::redact_url("redis://admin:hunter2@host:1"),
        "redis://admin:***@host:1"
    );
    assert_eq!(
        seam_transport::redact_url("redis://hunter2@host:1"),
        "redis://***@host:1"
    );
}

fn incompatible_settings_are_refused(backend: Backend) {
    let ctx = TestContext::new(backend).expect("iceoryx2 backends are always available");
    let channel = ctx.channel("small");
    // The first pod creates the channel for two subscribers; a pod that needs 16 cannot join.
    let mut first = ctx.open_with("max_subscribers=2");
    first.subscribe(&channel).expect("subscribe");
    let mut second = ctx.open();
    match second.subscribe(&channel) {
        Err(SubscribeError::IncompatibleService { channel: c, reason }) => {
            assert_eq!(c, channel);
            assert!(!reason.is_empty());
        }
        other => panic!("expected IncompatibleService, got {other:?}"),
    }
    let message = second
        .publish(&channel, b"x")
        .expect_err("publish is refused too");
    assert!(
        message.to_string().contains("incompatible settings"),
        "{message}"
    );
}

#[test]
fn shm_incompatible_settings_are_refused() {
    incompatible_settings_are_refused(Backend::Shm);
}

#[test]
fn local_incompatible_settings_are_refused() {
    incompatible_settings_are_refused(Backend::Local);
}

/// After `junk` foreign messages on `channel`, a real seam message is the only one delivered and
/// the junk is counted.
fn only_the_real_message_arrives(
    ctx: &TestContext,
    subscriber: &mut dyn Transport,
    channel: &str,
    junk: u64,
) {
    let mut seam = ctx.open();
    seam.publish(channel, b"real").expect("publish");
    let message = receive(subscriber, PATIENCE).expect("the real message arrives");
    assert_eq!(message.payload, b"real");
    assert_eq!(subscriber.stats().malformed_drops, junk);
    assert_eq!(subscriber.stats().received, 1);
}

/// Bytes published on a seam channel by something that is not seam are counted and skipped.
#[test]
fn redis_foreign_bytes_are_counted_and_skipped() {
    let Some(ctx) = TestContext::new(Backend::Redis) else {
        return;
    };
    let mut subscriber = ctx.open();
    let channel = ctx.channel("foreign");
    subscriber.subscribe(&channel).expect("subscribe");
    let client = redis::Client::open(redis_url()).expect("url");
    let mut raw = client.get_connection().expect("connect");
    for junk in [&b""[..], b"hello", &[0xFFu8; 40][..], &[0u8; 32][..]] {
        let reached: usize = redis::cmd("PUBLISH")
            .arg(&channel)
            .arg(junk)
            .query(&mut raw)
            .expect("publish");
        assert_eq!(reached, 1);
    }
    only_the_real_message_arrives(&ctx, subscriber.as_mut(), &channel, 4);
}

/// The same on shared memory: a raw iceoryx2 publisher writes samples whose header is not a
/// valid seam envelope.
#[test]
fn shm_foreign_samples_are_counted_and_skipped() {
    use iceoryx2::prelude::*;
    use seam_transport::Envelope;
    let Some(ctx) = TestContext::new(Backend::Shm) else {
        return;
    };
    let mut subscriber = ctx.open();
    let channel = ctx.channel("forged");
    subscriber.subscribe(&channel).expect("subscribe");

    let mut config = iceoryx2::config::Config::default();
    let prefix = ctx
        .url()
        .split("prefix=")
        .nth(1)
        .expect("prefix")
        .to_owned();
    config.global.prefix = FileName::new(prefix.as_bytes()).expect("prefix");
    let node = NodeBuilder::new()
        .config(&config)
        .create::<ipc::Service>()
        .expect("node");
    let service = node
        .service_builder(&ServiceName::new(&channel).expect("name"))
        .publish_subscribe::<[u8]>()
        .user_header::<Envelope>()
        .open()
        .expect("the channel exists");
    let publisher = service
        .publisher_builder()
        .initial_max_slice_len(64)
        .create()
        .expect("port");
    let forged = [
        Envelope::default(), // no magic
        Envelope {
            seq: 0,
            ..Envelope::new(1, 1, 4)
        }, // sequence 0
        Envelope::new(1, 1, 1000), // longer than the sample
        Envelope {
            version: 99,
            ..Envelope::new(1, 2, 4)
        }, // unknown version
    ];
    for envelope in forged {
        let mut sample = publisher
            .loan_slice_uninit(4)
            .expect("loan")
            .write_from_slice(b"junk");
        *sample.user_header_mut() = envelope;
        sample.send().expect("send");
    }
    only_the_real_message_arrives(&ctx, subscriber.as_mut(), &channel, 4);
}

/// A user and password in the URL authenticate both connections (a temporary ACL user), and
/// pods started with it run and report without printing it.
#[test]
fn redis_user_and_password_in_the_url_work() {
    let Some(ctx) = TestContext::new(Backend::Redis) else {
        return;
    };
    let user = format!("seam_test_{}", std::process::id());
    let password = format!("pw-{}-secret", std::process::id());
    let client = redis::Client::open(redis_url()).expect("url");
    let mut admin = client.get_connection().expect("connect");
    let created: redis::RedisResult<()> = redis::cmd("ACL")
        .arg("SETUSER")
        .arg(&user)
        .arg("on")
        .arg(format!(">{password}"))
        .arg("~*")
        .arg("&*")
        .arg("+@all")
        .query(&mut admin);
    created.expect("create a temporary ACL user");
    let url = redis_url().replacen("redis://", &format!("redis://{user}:{password}@"), 1);
    let result = std::panic::catch_unwind(|| {
        let mut publisher = seam_transport::open(&url).expect("open with user and password");
        let mut subscriber = seam_transport::open(&url).expect("open with user and password");
        let channel = ctx.channel("authenticated");
        subscriber.subscribe(&channel).expect("subscribe");
        assert_eq!(publisher.publish(&channel, b"in").expect("publish"), 1);
        let message = receive(subscriber.as_mut(), PATIENCE).expect("arrives");
        assert_eq!(message.payload, b"in");
        // Both connections of both transports are logged in as the user, not as `default`.
        let clients: String = redis::cmd("CLIENT")
            .arg("LIST")
            .query(&mut client.get_connection().expect("connect"))
            .expect("client list");
        let as_user = clients
            .lines()
            .filter(|line| line.contains(&format!(" user={user} ")))
            .count();
        assert_eq!(as_user, 4, "connections logged in as {user}:\n{clients}");
        drop((publisher, subscriber));

        // Pods started with the URL log in too, and neither the report nor its table names
        // the password.
        let plan = RunPlan {
            rate: 300.0,
            ticks: Some(600),
            node_command: vec![env!("CARGO_BIN_EXE_seam-test-node").into()],
            start_delay: Duration::from_millis(300),
            ..RunPlan::new(scene_path("crossfire.toml"), url.clone())
        };
        // While they run, the process list shows each pod's command line: no password there.
        let mut pods_seen = 0;
        let report = run::run(&plan, &AtomicBool::new(false), |_| {
            for cmdline in command_lines_with(&plan.run_id) {
                pods_seen += 1;
                assert!(
                    !cmdline.contains(&password),
                    "in the process list: {cmdline}"
                );
            }
        })
        .expect("pods run");
        assert!(pods_seen > 0, "the pods were looked for while they ran");
        assert!(report.pods.iter().all(|p| p.ticks == 600), "{report:?}");
        for text in [
            run::document(&report).text(),
            serde_json::to_string(&report).expect("json"),
        ] {
            assert!(!text.contains(&password), "the password leaked: {text}");
        }
    });
    let _: redis::RedisResult<()> = redis::cmd("ACL")
        .arg("DELUSER")
        .arg(&user)
        .query(&mut admin);
    if let Err(panic) = result {
        std::panic::resume_unwind(panic);
    }
}

/// The command lines of this host's processes that mention `needle`.
fn command_lines_with(needle: &str) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    entries
        .filter_map(Result::ok)
        .filter_map(|entry| std::fs::read(entry.path().join("cmdline")).ok())
        .map(|bytes| String::from_utf8_lossy(&bytes).replace('\0', " "))
        .filter(|line| line.contains(needle))
        .collect()
}
