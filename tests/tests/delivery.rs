//! No routed write lost, none applied twice: an op in a lost frame is sent again and applied
//! once; repeats and replays of an op are answered and never applied again; an op too old is
//! dropped and counted; an op whose owner died follows its entity to the adopter. Contact
//! reports likewise: one in a lost frame is sent again, and each surfaces once.

use std::time::Duration;

use seam_proxy::{AuthorityMode, Cluster, ClusterConfig, physics_events};
use seam_sim::BodyRole;
use seam_sim::wire::{
    self, ClusterId, ContactReport, EntityId, EntityState, OpAck, PhysicsEventsFrame, PhysicsOp,
    ReplicationFrame, RoutedOp, Stage,
};
use seam_tests::{HandClock, TestContext, ball_at, row_configs};

seam_tests::backend_tests!(
    [shm: Shm, local: Local, redis: Redis],
    [
        repeats_and_replays_of_an_op_are_applied_once,
        a_contact_report_surfaces_once_and_a_stale_one_not_at_all
    ]
);

/// The mass of `ball_at`'s ball (0.5 m radius, 100 kg/m³): an impulse of this many N·s gives
/// it 1 m/s.
fn ball_mass(_ball: &EntityState) -> f32 {
    100.0 * 4.0 / 3.0 * std::f32::consts::PI * 0.125
}

/// Two neighbouring clusters on `url`, zero gravity, scripted authority.
fn pair(url: &str, tune: impl Fn(&mut ClusterConfig)) -> (Vec<Cluster>, ClusterId, ClusterId) {
    let ids = [ClusterId::random(), ClusterId::random()];
    let clusters = (0..2)
        .map(|index| {
            let mut config = ClusterConfig::new(ids[index], vec![ids[1 - index]], url);
            config.gravity = [0.0; 3];
            config.authority = AuthorityMode::Scripted;
            tune(&mut config);
            Cluster::new(config).expect("cluster")
        })
        .collect();
    (clusters, ids[0], ids[1])
}

fn linvel_x(cluster: &Cluster, entity: EntityId) -> f32 {
    cluster.sim().state(entity).expect("state").linvel[0]
}

/// A writes to B's ball, then runs on while B stalls: B's buffer of 4 keeps only A's newest
/// frames, so the frame with the write is lost. A sends it again after `op_retry_ticks`; B
/// applies it once and answers, and A forgets it.
/// (On shared memory, whose receive buffer has a size to overflow.)
#[test]
fn an_op_in_a_lost_frame_is_sent_again_and_applied_once() {
    let ctx = TestContext::new(seam_transport::Backend::Shm).expect("shm is always there");
    let (mut clusters, _, b) = pair(&ctx.url_with("buffer=4"), |_| {});
    let ball = ball_at(1.0, b);
    let mass = ball_mass(&ball);
    clusters[1]
        .spawn_owned(&ball, BodyRole::Dynamic)
        .expect("spawn");
    for _ in 0..3 {
        for cluster in &mut clusters {
            cluster.tick(|_, _| {}).expect("tick");
        }
    }
    assert_eq!(
        clusters[0].sim().info(ball.id).map(|i| i.owner),
        Some(b),
        "A has a proxy of B's ball"
    );
    clusters[0]
        .tick(|_, physics| {
            physics
                .apply_impulse(ball.id, [mass, 0.0, 0.0])
                .expect("routed to B");
        })
        .expect("A writes");
    // A's last tick alone sends it again (two events frames a tick: B's buffer of 4 holds
    // those of A's last two ticks when B ticks again).
    let retry = clusters[0].config().op_retry_ticks;
    for _ in 0..retry {
        clusters[0].tick(|_, _| {}).expect("A ticks");
    }
    for _ in 0..5 {
        for cluster in &mut clusters {
            cluster.tick(|_, _| {}).expect("tick");
        }
    }
    let (sa, sb) = (clusters[0].stats(), clusters[1].stats());
    assert!(
        clusters[1].transport_stats().overflow_drops > 0,
        "B lost frames: {:?}",
        clusters[1].transport_stats()
    );
    assert_eq!(sa.ops_routed, 1, "{sa:?}");
    assert!(sa.ops_resent >= 1, "A sent it again: {sa:?}");
    assert_eq!(sb.ops_applied, 1, "B applied it once: {sb:?}");
    assert_eq!(
        (sa.ops_acked, clusters[0].ops_unanswered()),
        (1, 0),
        "{sa:?}"
    );
    let v = linvel_x(&clusters[1], ball.id);
    assert!((v - 1.0).abs() < 1e-3, "Δv = J/m, once: {v}");
}

/// A ball of A's touches B's ball: A's world reports the contact to B, whose buffer of 4 loses
/// the frame while B stalls. A sends the report again; B answers it, A forgets it, and B's game
/// code sees the contact start once (B's own world sees it too: the two copies merge).
#[test]
fn a_contact_report_in_a_lost_frame_is_sent_again_and_surfaces_once() {
    let ctx = TestContext::new(seam_transport::Backend::Shm).expect("shm is always there");
    let (mut clusters, a, b) = pair(&ctx.url_with("buffer=4"), |_| {});
    let theirs = ball_at(1.0, b);
    clusters[1]
        .spawn_owned(&theirs, BodyRole::Dynamic)
        .expect("spawn B's");
    for _ in 0..3 {
        for cluster in &mut clusters {
            cluster.tick(|_, _| {}).expect("tick");
        }
    }
    // Overlapping B's ball by 5 cm: the contact starts in A's next step.
    let ours = ball_at(0.05, a);
    clusters[0]
        .spawn_owned(&ours, BodyRole::Dynamic)
        .expect("spawn A's");
    let retry = clusters[0].config().op_retry_ticks;
    for _ in 0..retry + 2 {
        clusters[0].tick(|_, _| {}).expect("A ticks");
    }
    assert!(
        clusters[0].stats().contacts_sent >= 1,
        "A reported the contact: {:?}",
        clusters[0].stats()
    );
    let pair_of = |c: &seam_sim::ContactEvent| {
        (c.a == ours.id && c.b == theirs.id) || (c.a == theirs.id && c.b == ours.id)
    };
    let mut seen_by_b = 0;
    for _ in 0..8 {
        clusters[0].tick(|_, _| {}).expect("A ticks");
        clusters[1]
            .tick(|ctx, _| {
                seen_by_b += ctx
                    .contacts()
                    .iter()
                    .filter(|c| pair_of(c) && c.started)
                    .count();
            })
            .expect("B ticks");
    }
    let (sa, sb) = (clusters[0].stats(), clusters[1].stats());
    assert!(
        clusters[1].transport_stats().overflow_drops > 0,
        "B lost frames: {:?}",
        clusters[1].transport_stats()
    );
    assert!(sa.contacts_resent >= 1, "A sent it again: {sa:?}");
    assert!(
        sb.contacts_received > sb.contacts_repeated + sb.contacts_dropped_stale,
        "B took it in: {sb:?}"
    );
    assert_eq!(
        (sa.contacts_acked, clusters[0].contacts_unanswered()),
        (sa.contacts_sent, 0),
        "every report answered: {sa:?}"
    );
    assert_eq!(seen_by_b, 1, "B's game code saw the start once: {sb:?}");
}

/// The numbers the test gives its ops: as a pod's, microseconds of the wall clock.
const SEQ: u64 = 1_796_000_000_000_000;

/// An events frame from `from`, tagged `tick`, with `ops`.
fn frame(from: ClusterId, tick: u64, ops: Vec<RoutedOp>) -> Vec<u8> {
    wire::encode(&PhysicsEventsFrame {
        incarnation: 0,
        from,
        tick,
        stage: Stage::AfterStep,
        published_ns: 0,
        ops,
        acks: Vec::new(),
        contacts: Vec::new(),
        impulses: Vec::new(),
        own_writes: Vec::new(),
        leaving: false,
        unmodelled: Vec::new(),
    })
}

fn op(op: PhysicsOp, seq: u64, age_ticks: u32) -> RoutedOp {
    RoutedOp {
        op,
        seq,
        issuer: None,
        issued_ns: 0,
        issued_tick: 0,
        age_ticks,
    }
}

/// The test plays B's neighbour A by hand, on a real transport: it sends B an impulse, the
/// same frame again (a replay), the same op in a later frame (a resend), an op too old, one
/// numbered below B's window of A's numbers, and one for an entity B does not know. B applies
/// the impulse once, counts each of the others by what it is, and answers every op on A's
/// channel — "done" but for the unknown entity, "not here".
fn repeats_and_replays_of_an_op_are_applied_once(ctx: &TestContext) {
    let (a, b) = (ClusterId::random(), ClusterId::random());
    let mut config = ClusterConfig::new(b, vec![a], &ctx.url());
    config.gravity = [0.0; 3];
    config.authority = AuthorityMode::Scripted;
    let mut cluster = Cluster::new(config).expect("cluster B");
    let ball = ball_at(1.0, b);
    let mass = ball_mass(&ball);
    cluster
        .spawn_owned(&ball, BodyRole::Dynamic)
        .expect("spawn");
    let mut injector = ctx.open();
    injector.subscribe(&physics_events(a)).expect("subscribe");
    let to_b = physics_events(b);
    let push = PhysicsOp::Impulse {
        target: ball.id,
        impulse: [mass, 0.0, 0.0],
    };
    let max_age = cluster.config().max_op_age_ticks as u32;
    let unknown = PhysicsOp::Wake {
        target: EntityId::random(),
    };
    let frames = [
        frame(a, 1, vec![op(push, SEQ, 0)]),
        frame(a, 1, vec![op(push, SEQ, 0)]),
        frame(a, 2, vec![op(push, SEQ, 3)]),
        frame(a, 3, vec![op(push, SEQ + 1, max_age)]),
        frame(a, 4, vec![op(push, SEQ + 100_000, 0)]),
        frame(a, 5, vec![op(push, SEQ + 100_000 - 20_000, 0)]),
        frame(a, 6, vec![op(unknown, SEQ + 100_001, 0)]),
        frame(
            a,
            7,
            (0..3)
                .map(|i| op(PhysicsOp::Wake { target: ball.id }, SEQ + 100_002 + i, 0))
                .collect(),
        ),
    ];
    let mut answers: Vec<OpAck> = Vec::new();
    for bytes in &frames {
        injector.publish(&to_b, bytes).expect("publish");
        // One tick per frame, after it has arrived, so each is judged alone.
        std::thread::sleep(Duration::from_millis(20));
        cluster.wait(Duration::from_millis(200)).expect("wait");
        cluster.tick(|_, _| {}).expect("tick");
        while let Some(message) = seam_tests::receive(injector.as_mut(), Duration::from_millis(200))
        {
            let reply: PhysicsEventsFrame = wire::decode(&message.payload).expect("B's frame");
            answers.extend(reply.acks);
            // Up to B's frame after this tick's step (the one before it, the exchange,
            // carries no answers).
            if reply.stage == Stage::AfterStep && reply.tick == cluster.sim().tick() {
                break;
            }
        }
    }
    let s = cluster.stats();
    assert_eq!(s.frames_replayed, 1, "the same frame twice: {s:?}");
    assert_eq!(
        s.ops_applied, 5,
        "the push, the new number far ahead, three wakes: {s:?}"
    );
    assert_eq!(s.ops_repeated, 1, "the push in a later frame: {s:?}");
    assert_eq!(s.ops_dropped_stale, 1, "{s:?}");
    assert_eq!(s.ops_dropped_window, 1, "{s:?}");
    assert_eq!(s.ops_not_here, 1, "{s:?}");
    let v = linvel_x(&cluster, ball.id);
    assert!(
        (v - 2.0).abs() < 1e-3,
        "two pushes of 1 m/s applied, no more: {v}"
    );
    let done = |seq: u64| {
        answers
            .iter()
            .filter(|a| a.seqs().contains(&seq) && a.done)
            .count()
    };
    assert_eq!(
        done(SEQ),
        2,
        "the push and its resend answered: {answers:?}"
    );
    for seq in [SEQ + 1, SEQ + 100_000, SEQ + 80_000] {
        assert_eq!(done(seq), 1, "seq {seq} answered: {answers:?}");
    }
    assert!(
        answers.iter().any(|a| a.seq == SEQ + 100_001 && !a.done),
        "the unknown entity answered not here: {answers:?}"
    );
    assert!(
        answers
            .iter()
            .any(|a| a.seq == SEQ + 100_002 && a.more == 2 && a.done),
        "three consecutive numbers answered in one: {answers:?}"
    );
}

/// A contact report of `a` and `b` starting, numbered `seq`, `age_ticks` old.
fn report(a: EntityId, b: EntityId, started: bool, seq: u64, age_ticks: u32) -> ContactReport {
    ContactReport {
        seq,
        age_ticks,
        a,
        b,
        started,
        tick: 0,
        impulse: [0.0; 3],
        normal: [1.0, 0.0, 0.0],
    }
}

/// The test plays B's neighbour A by hand: it reports a contact start, the same report again
/// in a later frame (a resend, aged past the window two copies merge in), a report too old,
/// and the contact's stop; then, 10 ticks on, a late report (aged 12) of a contact B's own
/// world saw start in its first steps (B's ball against its proxy of a ball A replicates).
/// B's game code sees the start and the stop, once each, and not the late copy of what it saw
/// itself; B counts the repeat and the stale report, and answers every report.
fn a_contact_report_surfaces_once_and_a_stale_one_not_at_all(ctx: &TestContext) {
    let (a, b) = (ClusterId::random(), ClusterId::random());
    let mut config = ClusterConfig::new(b, vec![a], &ctx.url());
    config.gravity = [0.0; 3];
    config.authority = AuthorityMode::Scripted;
    let mut cluster = Cluster::new(config).expect("cluster B");
    let ball = ball_at(1.0, b);
    // A ball of B's and one of A's overlapping by 10 cm, far off: B's world sees its ball
    // start touching its proxy of A's.
    let (near, far) = (ball_at(10.0, b), ball_at(10.9, a));
    for body in [&ball, &near] {
        cluster.spawn_owned(body, BodyRole::Dynamic).expect("spawn");
    }
    let mut injector = ctx.open();
    injector.subscribe(&physics_events(a)).expect("subscribe");
    let to_b = physics_events(b);
    let (theirs, other) = (EntityId::random(), EntityId::random());
    let max_age = cluster.config().max_op_age_ticks as u32;
    let mut reports = vec![
        Some(report(theirs, ball.id, true, SEQ, 0)),
        Some(report(theirs, ball.id, true, SEQ, 12)),
        Some(report(other, ball.id, true, SEQ + 1, max_age)),
        Some(report(theirs, ball.id, false, SEQ + 2, 0)),
    ];
    reports.extend([None; 10]);
    reports.push(Some(report(far.id, near.id, true, SEQ + 3, 12)));
    let mut answers: Vec<OpAck> = Vec::new();
    let mut seen = Vec::new();
    for (tick, report) in (1..).zip(reports) {
        let replication = ReplicationFrame {
            incarnation: 0,
            from: a,
            tick,
            states: vec![far],
        };
        let bytes = replication
            .encode(wire::StateEncoding::Exact)
            .expect("encodes");
        injector
            .publish(&seam_proxy::replication(a), &bytes)
            .expect("publish");
        let bytes = wire::encode(&PhysicsEventsFrame {
            incarnation: 0,
            from: a,
            tick,
            stage: Stage::AfterStep,
            published_ns: 0,
            ops: Vec::new(),
            acks: Vec::new(),
            contacts: report.into_iter().collect(),
            impulses: Vec::new(),
            own_writes: Vec::new(),
            leaving: false,
            unmodelled: Vec::new(),
        });
        injector.publish(&to_b, &bytes).expect("publish");
        std::thread::sleep(Duration::from_millis(20));
        cluster.wait(Duration::from_millis(200)).expect("wait");
        cluster
            .tick(|ctx, _| {
                seen.extend(
                    ctx.contacts()
                        .iter()
                        .filter(|c| c.reported_by == Some(a))
                        .map(|c| (c.a, c.started)),
                );
            })
            .expect("tick");
        while let Some(message) = seam_tests::receive(injector.as_mut(), Duration::from_millis(200))
        {
            let reply: PhysicsEventsFrame = wire::decode(&message.payload).expect("B's frame");
            answers.extend(reply.acks);
            // Up to B's frame after this tick's step (the one before it, the exchange,
            // carries no answers).
            if reply.stage == Stage::AfterStep && reply.tick == cluster.sim().tick() {
                break;
            }
        }
    }
    let s = cluster.stats();
    assert_eq!(
        seen,
        vec![(theirs, true), (theirs, false)],
        "the start and the stop, once each: {s:?}"
    );
    assert_eq!(
        (
            s.contacts_received,
            s.contacts_repeated,
            s.contacts_dropped_stale,
            s.contacts_merged
        ),
        (5, 1, 1, 1),
        "{s:?}"
    );
    let done = |seq: u64| {
        answers
            .iter()
            .filter(|a| a.seqs().contains(&seq) && a.done)
            .count()
    };
    assert_eq!(done(SEQ), 2, "the report and its resend: {answers:?}");
    assert_eq!(
        (done(SEQ + 1), done(SEQ + 2), done(SEQ + 3)),
        (1, 1, 1),
        "{answers:?}"
    );
}

/// West [-30, 0] and east [0, 30] with a world map; east owns a ball at x = 1. West writes to
/// it, and east dies before reading the write. West takes east for dead after the timeout,
/// adopts the ball, and applies its own unanswered write to it — once — if the write is still
/// young enough (`max_op_age_ticks`), or drops it as too old, counted.
fn dead_owner(max_op_age_ticks: u64) -> (Cluster, EntityState) {
    let url = format!(
        "local?prefix=seam_delivery_dead_{}_{max_op_age_ticks}_",
        std::process::id()
    );
    let mut clusters: Vec<Cluster> = row_configs(&url, &[(-30.0, 0.0), (0.0, 30.0)])
        .into_iter()
        .map(|mut config| {
            config.spread = 40.0;
            config.neighbour_timeout_ticks = 10;
            config.max_op_age_ticks = max_op_age_ticks;
            config.authority = AuthorityMode::Scripted;
            Cluster::new(config).expect("cluster")
        })
        .collect();
    let ball = ball_at(1.0, clusters[1].id());
    let mass = ball_mass(&ball);
    clusters[1]
        .spawn_owned(&ball, BodyRole::Dynamic)
        .expect("spawn");
    let mut clock = HandClock::new(clusters[0].config().dt);
    for _ in 0..3 {
        let now = clock.advance();
        for cluster in &mut clusters {
            cluster.tick_at(now, |_, _| {}).expect("tick");
        }
    }
    let east = clusters.pop().expect("east");
    let mut west = clusters.pop().expect("west");
    west.tick_at(clock.advance(), |_, physics| {
        physics
            .apply_impulse(ball.id, [mass, 0.0, 0.0])
            .expect("routed to east");
    })
    .expect("west writes");
    // East dies unread (no leave: a crash), its transport with it.
    drop(east);
    for _ in 0..40 {
        west.tick_at(clock.advance(), |_, _| {})
            .expect("west ticks");
    }
    (west, ball)
}

#[test]
fn a_write_to_a_dead_owner_is_applied_once_by_the_adopter() {
    let (west, ball) = dead_owner(30);
    let s = west.stats();
    assert_eq!(s.entities_adopted, 1, "{s:?}");
    assert_eq!(
        s.ops_applied, 1,
        "west, now the owner, applied its write: {s:?}"
    );
    assert_eq!(west.ops_unanswered(), 0);
    let v = linvel_x(&west, ball.id);
    assert!((v - 1.0).abs() < 1e-3, "Δv = J/m, once: {v}");
}

#[test]
fn a_write_older_than_its_age_limit_is_dropped_and_counted() {
    let (west, ball) = dead_owner(5);
    let s = west.stats();
    assert_eq!(s.entities_adopted, 1, "{s:?}");
    assert_eq!(
        (s.ops_applied, s.ops_dropped_stale + s.ops_expired),
        (0, 1),
        "dropped as too old by west, its owner now: {s:?}"
    );
    assert_eq!(west.ops_unanswered(), 0);
    assert_eq!(linvel_x(&west, ball.id), 0.0, "not applied");
}
