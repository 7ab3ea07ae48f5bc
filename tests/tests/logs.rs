//! Nothing lost without a word (issue 37): what a cluster drops or refuses is counted and logged
//! as a warning naming the cluster and, where it has them, the entity and the other cluster by
//! name, on shared memory and on Redis. West lists east as its neighbour, east lists nobody:
//! east publishes, so west hears it and models its crate, but east never reads what west sends.
//!
//! - west's hand-off of its ball to east comes back untaken: logged with the ball's name and
//!   east's;
//! - west's push on east's crate is never answered and is given up: logged with west's name and
//!   the count by reason;
//! - a replication frame on east's channel claiming to be from a stranger is refused: logged
//!   with the stranger's name.

use std::io::Write;
use std::sync::{Arc, Mutex};

use seam_proxy::{AuthorityMode, Cluster, ClusterConfig};
use seam_sim::BodyRole;
use seam_sim::wire::{ClusterId, ReplicationFrame, StateEncoding};
use seam_tests::{TestContext, ball_at, row_configs};

seam_tests::backend_tests!(
    [shm: Shm, redis: Redis],
    [drops_and_refusals_are_logged_by_name]
);

/// Log lines written by the test's subscriber.
#[derive(Clone, Default)]
struct Captured(Arc<Mutex<Vec<u8>>>);

impl Write for Captured {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.lock().expect("log buffer").extend_from_slice(bytes);
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl<'a> tracing_subscriber::fmt::MakeWriter<'a> for Captured {
    type Writer = Captured;

    fn make_writer(&'a self) -> Self::Writer {
        self.clone()
    }
}

impl Captured {
    /// The warnings logged so far, one a line.
    fn warnings(&self) -> Vec<String> {
        String::from_utf8_lossy(&self.0.lock().expect("log buffer"))
            .lines()
            .filter(|line| line.contains("WARN"))
            .map(str::to_owned)
            .collect()
    }
}

/// West ([-30, -10]) and east ([10, 30]), spread 4 m, named, moved only by game code; west
/// lists east, east lists nobody.
fn pair(url: &str, stranger: ClusterId) -> (ClusterConfig, ClusterConfig) {
    let mut configs = row_configs(url, &[(-30.0, -10.0), (-10.0, 10.0), (10.0, 30.0)]);
    let (west, east) = (configs[0].cluster_id, configs[2].cluster_id);
    for config in &mut configs {
        config.spread = 4.0;
        config.authority = AuthorityMode::Scripted;
        config.names = [(west, "west"), (east, "east"), (stranger, "stranger")]
            .into_iter()
            .map(|(id, name)| (id, name.to_owned()))
            .collect();
    }
    configs[0].neighbours = vec![east];
    configs[2].neighbours = Vec::new();
    (configs[0].clone(), configs[2].clone())
}

fn drops_and_refusals_are_logged_by_name(ctx: &TestContext) {
    let stranger = ClusterId::random();
    let (west_config, east_config) = pair(&ctx.url(), stranger);
    let captured = Captured::default();
    let subscriber = tracing_subscriber::fmt()
        .with_writer(captured.clone())
        .with_ansi(false)
        .with_max_level(tracing::Level::WARN)
        .finish();
    let (timeout, max_age) = (
        west_config.neighbour_timeout_ticks,
        west_config.max_op_age_ticks,
    );
    let stats = tracing::subscriber::with_default(subscriber, || {
        let mut west = Cluster::new(west_config).expect("west");
        let mut east = Cluster::new(east_config).expect("east");
        // West's ball, near east's region (east models it, had it read west's frames), and
        // east's crate, near west's (west models it).
        let ball = ball_at(8.0, west.id());
        west.spawn_owned(&ball, BodyRole::Dynamic).expect("ball");
        west.name_entity(ball.id, "icy-ball").expect("a name");
        let crate_ = ball_at(-8.0, east.id());
        east.spawn_owned(&crate_, BodyRole::Dynamic).expect("crate");
        west.name_entity(crate_.id, "crate-7").expect("a name");
        let remote = ctx.url().starts_with("redis");
        let tick_both = |west: &mut Cluster, east: &mut Cluster, push: bool| {
            east.tick(|_, _| {}).expect("east ticks");
            west.tick(|_, physics| {
                if push {
                    physics
                        .apply_impulse(crate_.id, [0.0, 10.0, 0.0])
                        .expect("routed to east");
                }
            })
            .expect("west ticks");
            if remote {
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
        };
        for _ in 0..5 {
            tick_both(&mut west, &mut east, false);
        }
        assert!(
            west.sim().state(crate_.id).is_some(),
            "west models the crate"
        );
        let east_id = east.id();
        west.transfer_authority(ball.id, east_id)
            .expect("east is heard and would model the ball");
        tick_both(&mut west, &mut east, true);
        // A frame on east's channel claiming a stranger sent it.
        let forged = ReplicationFrame {
            from: stranger,
            tick: 1,
            incarnation: 1,
            states: Vec::new(),
        };
        let mut forger = seam_transport::open(&ctx.url()).expect("a forger");
        forger
            .publish(
                &seam_proxy::replication(east_id),
                &forged.encode(StateEncoding::Exact).expect("encodes"),
            )
            .expect("publish");
        // An op is given up `max_op_age_ticks` and twice the neighbour timeout after it was made.
        for _ in 0..max_age + 2 * timeout + 10 {
            tick_both(&mut west, &mut east, false);
        }
        west.stats()
    });
    assert_eq!(stats.handoffs_returned, 1, "{stats:#}");
    assert!(stats.ops_expired >= 1, "{stats:#}");
    assert!(stats.frames_wrong_sender >= 1, "{stats:#}");
    let warnings = captured.warnings();
    let has = |needles: &[&str]| {
        warnings
            .iter()
            .any(|w| needles.iter().all(|n| w.contains(n)))
    };
    assert!(
        has(&["hand-off not taken", "icy-ball (", "east (", "west ("]),
        "the returned hand-off, by name: {warnings:#?}"
    );
    assert!(
        has(&["routed ops dropped", "west (", "unanswered_too_long=1"]),
        "the op given up, by name and reason: {warnings:#?}"
    );
    assert!(
        has(&["frame refused", "stranger (", "WrongSender"]),
        "the forged frame, naming who it claims to be from: {warnings:#?}"
    );
}
