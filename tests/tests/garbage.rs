//! Untrusted input on a live cluster's channels: 100 000 frames of garbage, truncated and
//! wrong-version frames, forged ownership, duplicates and ops with NaN, absurd or unknown
//! targets, published into a cluster's `physics_events` and neighbour `replication` channels
//! over shm and over Redis while it ticks. Every frame is accounted for by reason, nothing
//! panics, and the world is bit-for-bit unchanged.

use std::time::{Duration, Instant};

use seam_proxy::{Cluster, ClusterConfig, ClusterStats, physics_events, replication};
use seam_sim::BodyRole;
use seam_sim::wire::{
    self, ClusterId, EntityId, EntityState, PhysicsEventsFrame, PhysicsOp, ReplicationFrame,
    RoutedOp,
};
use seam_tests::{TestContext, ball_at};

seam_tests::backend_tests!([shm: Shm, redis: Redis], [flood_is_counted_and_changes_nothing]);

const FRAMES: u64 = 100_000;

/// xorshift64*: reproducible noise without a dependency.
struct Noise(u64);

impl Noise {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn bytes(&mut self, max: u64) -> Vec<u8> {
        let len = self.next() % (max + 1);
        (0..len).map(|_| self.next() as u8).collect()
    }
}

fn accounted(s: &ClusterStats) -> u64 {
    s.frames_accepted
        + s.frames_malformed
        + s.frames_wrong_version
        + s.frames_wrong_sender
        + s.frames_duplicate
}

fn flood_is_counted_and_changes_nothing(ctx: &TestContext) {
    let (me, neighbour) = (ClusterId::random(), ClusterId::random());
    let mut config = ClusterConfig::new(me, vec![neighbour], &ctx.url());
    config.gravity = [0.0; 3];
    config.neighbour_timeout_ticks = 0;
    let mut cluster = Cluster::new(config).expect("cluster");
    let mine: Vec<EntityState> = (0..5).map(|i| ball_at(i as f32 * 3.0, me)).collect();
    for state in &mine {
        cluster
            .spawn_owned(state, BodyRole::Dynamic)
            .expect("spawn");
    }
    cluster.tick(|_, _| {}).expect("tick");
    let snapshot = |cluster: &Cluster| -> Vec<[u32; 13]> {
        mine.iter()
            .map(|s| {
                cluster
                    .sim()
                    .state(s.id)
                    .expect("still there")
                    .motion_bits()
            })
            .collect()
    };
    let before = snapshot(&cluster);

    let mut injector = ctx.open();
    let (events_channel, replication_channel) = (physics_events(me), replication(neighbour));
    let mut noise = Noise(0x005e_ed0f_5ea7);
    let op_frame = |tick: u64, op: PhysicsOp| PhysicsEventsFrame {
        from: neighbour,
        tick,
        published_ns: 0,
        ops: vec![RoutedOp {
            op,
            issued_ns: 0,
            issued_tick: 0,
        }],
        contacts: Vec::new(),
    };
    let target = mine[0].id;
    let mut injected = 0u64;
    let mut tick_tag = 1_000_000u64;
    while injected < FRAMES {
        for _ in 0..8 {
            tick_tag += 1;
            let kind = noise.next() % 9;
            let (channel, payloads): (&str, Vec<Vec<u8>>) = match kind {
                // Random bytes, on either channel.
                0 => (&events_channel, vec![noise.bytes(300)]),
                1 => (&replication_channel, vec![noise.bytes(300)]),
                // Another format version.
                2 => {
                    let mut bytes = wire::encode(&op_frame(tick_tag, PhysicsOp::Wake { target }));
                    bytes[0] = wire::WIRE_VERSION.wrapping_add(1 + (noise.next() % 200) as u8);
                    (&events_channel, vec![bytes])
                }
                // A valid frame cut short.
                3 => {
                    let bytes = wire::encode(&op_frame(
                        tick_tag,
                        PhysicsOp::Impulse {
                            target,
                            impulse: [1.0, 2.0, 3.0],
                        },
                    ));
                    let cut = 1 + (noise.next() as usize) % (bytes.len() - 1);
                    (&events_channel, vec![bytes[..cut].to_vec()])
                }
                // Ops that must not apply: NaN, a light-year away, an absurd impulse, unknown.
                4 => {
                    let op = match noise.next() % 4 {
                        0 => PhysicsOp::Impulse {
                            target,
                            impulse: [f32::NAN, 0.0, 0.0],
                        },
                        1 => PhysicsOp::SetTranslation {
                            target,
                            translation: [9.46e15, 0.0, 0.0],
                        },
                        2 => PhysicsOp::Impulse {
                            target,
                            impulse: [0.0, 1.0e12, 0.0],
                        },
                        _ => PhysicsOp::SetLinvel {
                            target: EntityId::random(),
                            linvel: [1.0, 0.0, 0.0],
                        },
                    };
                    (&events_channel, vec![wire::encode(&op_frame(tick_tag, op))])
                }
                // Forged ownership: the neighbour claims this cluster's entities.
                5 => {
                    let mut forged = mine[(noise.next() % 5) as usize];
                    forged.cluster_id = neighbour;
                    forged.position[1] += 10.0;
                    let frame = ReplicationFrame {
                        from: neighbour,
                        tick: tick_tag,
                        states: vec![forged],
                    };
                    (&replication_channel, vec![wire::encode(&frame)])
                }
                // A replication frame on the neighbour's channel naming another sender.
                6 => {
                    let frame = ReplicationFrame {
                        from: me,
                        tick: tick_tag,
                        states: Vec::new(),
                    };
                    (&replication_channel, vec![wire::encode(&frame)])
                }
                // An events frame from a cluster that is not a neighbour.
                7 => {
                    let mut frame = op_frame(tick_tag, PhysicsOp::Wake { target });
                    frame.from = ClusterId::random();
                    (&events_channel, vec![wire::encode(&frame)])
                }
                // The same frame twice (a replay): the second is a duplicate.
                _ => {
                    let bytes = wire::encode(&op_frame(
                        tick_tag,
                        PhysicsOp::SetLinvel {
                            target: EntityId::random(),
                            linvel: [0.0; 3],
                        },
                    ));
                    (&events_channel, vec![bytes.clone(), bytes])
                }
            };
            for payload in payloads {
                injector.publish(channel, &payload).expect("publish");
                injected += 1;
            }
        }
        cluster.tick(|_, _| {}).expect("the cluster keeps ticking");
    }
    // Redis delivers asynchronously: tick until every frame has been seen.
    let deadline = Instant::now() + Duration::from_secs(60);
    while accounted(&cluster.stats()) + cluster.transport_stats().overflow_drops < injected
        && Instant::now() < deadline
    {
        cluster.tick(|_, _| {}).expect("tick");
        std::thread::sleep(Duration::from_millis(1));
    }

    let s = cluster.stats();
    let t = cluster.transport_stats();
    assert_eq!(
        accounted(&s) + t.overflow_drops + t.malformed_drops,
        injected,
        "every frame accounted for: {s:?} {t:?}"
    );
    assert_eq!(t.overflow_drops, 0, "ticks kept up with the flood");
    for (what, count) in [
        ("undecodable", s.frames_malformed),
        ("wrong version", s.frames_wrong_version),
        ("wrong sender", s.frames_wrong_sender),
        ("duplicate", s.frames_duplicate),
        ("NaN ops", s.ops_dropped_invalid),
        ("absurd ops", s.ops_dropped_absurd),
        ("ops for unknown entities", s.ops_dropped_not_owner),
        ("forged states", s.states_rejected),
    ] {
        assert!(count > 0, "{what} seen and counted: {s:?}");
    }
    assert_eq!(s.ops_applied, 0, "no op applied: {s:?}");
    assert_eq!(cluster.sim().len(), mine.len(), "no entity added or lost");
    assert_eq!(
        snapshot(&cluster),
        before,
        "the world is bit-for-bit unchanged"
    );
}
