//! Untrusted input on a live cluster's channels: 100 000 frames of garbage, truncated and
//! wrong-version frames, forged ownership, replays, frames tagged far in the future, states
//! with NaN or absurd values and ops with NaN, absurd or unknown targets, published into a
//! cluster's `physics_events` and neighbour `replication` channels over shm and over Redis
//! while it ticks, with default settings (liveness on). Every frame and every state or op in a
//! taken frame is counted under the reason it was injected for — each counter equal to what
//! was injected of its kind — nothing panics, and the world is bit-for-bit unchanged.

use std::time::{Duration, Instant};

use seam_proxy::{
    Cluster, ClusterConfig, ClusterEvent, ClusterStats, FrameRefusal, physics_events, replication,
};
use seam_sim::BodyRole;
use seam_sim::wire::{
    self, ClusterId, EntityId, EntityState, PhysicsEventsFrame, PhysicsOp, ReplicationFrame,
    ReplicationView, RoutedOp, Shape, Stage, StateEncoding,
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

/// What the injected frames must be counted as, tallied while injecting.
#[derive(Debug, Default, PartialEq, Eq)]
struct Tally {
    accepted: u64,
    malformed: u64,
    wrong_version: u64,
    wrong_sender: u64,
    replayed: u64,
    implausible: u64,
    ops_invalid: u64,
    ops_absurd: u64,
    ops_not_owner: u64,
    states_rejected: u64,
}

impl Tally {
    fn of(s: &ClusterStats) -> Self {
        Self {
            accepted: s.frames_accepted,
            malformed: s.frames_malformed,
            wrong_version: s.frames_wrong_version,
            wrong_sender: s.frames_wrong_sender,
            replayed: s.frames_replayed,
            implausible: s.frames_implausible,
            ops_invalid: s.ops_dropped_invalid,
            ops_absurd: s.ops_dropped_absurd,
            ops_not_owner: s.ops_not_here,
            states_rejected: s.states_rejected,
        }
    }

    fn frames(&self) -> u64 {
        self.accepted
            + self.malformed
            + self.wrong_version
            + self.wrong_sender
            + self.replayed
            + self.implausible
    }

    /// Random bytes are refused as another version unless their first byte happens to be this
    /// one's; then as undecodable (were they ever a valid frame, the seed would need changing).
    fn noise<T>(&mut self, decoded: Result<T, wire::WireError>) {
        match decoded {
            Err(wire::WireError::Version { .. }) => self.wrong_version += 1,
            Err(_) => self.malformed += 1,
            Ok(_) => panic!("noise decoded as a frame: pick another seed"),
        }
    }
}

/// States a neighbour may not make this cluster model: NaN, infinite or absurd poses and
/// velocities, a rotation that is not one, a shape with no size — all for an entity it would
/// otherwise proxy.
fn bad_state(noise: &mut Noise, owner: ClusterId) -> EntityState {
    let mut state = ball_at(1.0, owner);
    match noise.next() % 7 {
        0 => state.position[1] = f32::NAN,
        1 => state.position[2] = 2.0e6,
        2 => state.linvel[0] = f32::INFINITY,
        3 => state.linvel[1] = -5.0e6,
        4 => state.angvel[2] = 3.0e6,
        5 => state.rotation = [0.0, 0.0, 0.0, 7.0],
        _ => state.body.shape = Shape::Ball { radius: f32::NAN },
    }
    state
}

/// A replication frame as pods publish it by default.
fn exact(frame: &ReplicationFrame) -> Vec<u8> {
    frame.encode(StateEncoding::Exact).expect("encodes")
}

fn flood_is_counted_and_changes_nothing(ctx: &TestContext) {
    let (me, neighbour) = (ClusterId::random(), ClusterId::random());
    let mut config = ClusterConfig::new(me, vec![neighbour], &ctx.url());
    assert!(
        config.neighbour_timeout_ticks > 0,
        "liveness (and with it the future-tick check) is on by default"
    );
    config.gravity = [0.0; 3];
    let mut cluster = Cluster::new(config).expect("cluster");
    cluster.keep_events();
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
    let op_frame = |tick: u64, ops: Vec<PhysicsOp>| PhysicsEventsFrame {
        incarnation: 0,
        from: neighbour,
        tick,
        stage: Stage::AfterStep,
        published_ns: 0,
        // Numbered apart, so none is taken for a repeat of another.
        ops: ops
            .into_iter()
            .enumerate()
            .map(|(i, op)| RoutedOp {
                op,
                seq: tick * 16 + i as u64,
                issuer: None,
                issued_ns: 0,
                issued_tick: 0,
                age_ticks: 0,
            })
            .collect(),
        acks: Vec::new(),
        contacts: Vec::new(),
        impulses: Vec::new(),
        own_writes: Vec::new(),
        leaving: false,
        unmodelled: Vec::new(),
    };
    let target = mine[0].id;
    let mut expected = Tally::default();
    // The neighbour is heard first with an honest frame: from then on it is alive, so replays
    // and frames tagged far ahead of it are judged as such.
    let mut tick_tag = 1_000_000u64;
    injector
        .publish(
            &events_channel,
            &wire::encode(&op_frame(tick_tag, Vec::new())),
        )
        .expect("publish");
    expected.accepted += 1;
    // Batches of 8, each with at most one replication frame that a tick takes (a free-running
    // cluster keeps only the newest of a sender's frames, so a second would hide the first's
    // states), and the cluster ticks until the batch is counted: on every transport each
    // taken frame is judged in full.
    while expected.frames() < FRAMES {
        let mut states_sent = false;
        for _ in 0..8 {
            tick_tag += 1;
            let kind = loop {
                let kind = noise.next() % 12;
                let with_states = matches!(kind, 5 | 10 | 11);
                if !(states_sent && with_states) {
                    states_sent |= with_states;
                    break kind;
                }
            };
            let (channel, payloads): (&str, Vec<Vec<u8>>) = match kind {
                // Random bytes, on either channel.
                0 => {
                    let bytes = noise.bytes(300);
                    expected.noise(wire::decode::<PhysicsEventsFrame>(&bytes));
                    (&events_channel, vec![bytes])
                }
                1 => {
                    let bytes = noise.bytes(300);
                    // A cluster checks a replication frame's shape on arrival, its records in use.
                    expected.noise(ReplicationView::parse(&bytes));
                    (&replication_channel, vec![bytes])
                }
                // Another format version.
                2 => {
                    let mut bytes =
                        wire::encode(&op_frame(tick_tag, vec![PhysicsOp::Wake { target }]));
                    bytes[0] = wire::WIRE_VERSION.wrapping_add(1 + (noise.next() % 200) as u8);
                    expected.wrong_version += 1;
                    (&events_channel, vec![bytes])
                }
                // A valid frame cut short.
                3 => {
                    let bytes = wire::encode(&op_frame(
                        tick_tag,
                        vec![PhysicsOp::Impulse {
                            target,
                            impulse: [1.0, 2.0, 3.0],
                        }],
                    ));
                    let cut = 1 + (noise.next() as usize) % (bytes.len() - 1);
                    expected.malformed += 1;
                    (&events_channel, vec![bytes[..cut].to_vec()])
                }
                // A taken frame of ops that must not apply: NaN, a light-year away, an absurd
                // impulse, an unknown target.
                4 => {
                    let ops = vec![
                        PhysicsOp::Impulse {
                            target,
                            impulse: [f32::NAN, 0.0, 0.0],
                        },
                        PhysicsOp::SetTranslation {
                            target,
                            translation: [9.46e15, 0.0, 0.0],
                        },
                        PhysicsOp::Impulse {
                            target,
                            impulse: [0.0, 1.0e12, 0.0],
                        },
                        PhysicsOp::SetLinvel {
                            target: EntityId::random(),
                            linvel: [1.0, 0.0, 0.0],
                        },
                    ];
                    expected.accepted += 1;
                    expected.ops_invalid += 1;
                    expected.ops_absurd += 2;
                    expected.ops_not_owner += 1;
                    (
                        &events_channel,
                        vec![wire::encode(&op_frame(tick_tag, ops))],
                    )
                }
                // Forged ownership: the neighbour claims this cluster's entities.
                5 => {
                    let mut forged = mine[(noise.next() % 5) as usize];
                    forged.cluster_id = neighbour;
                    forged.position[1] += 10.0;
                    let frame = ReplicationFrame {
                        incarnation: 0,
                        from: neighbour,
                        tick: tick_tag,
                        states: vec![forged],
                    };
                    expected.accepted += 1;
                    expected.states_rejected += 1;
                    (&replication_channel, vec![exact(&frame)])
                }
                // A replication frame on the neighbour's channel naming another sender.
                6 => {
                    let frame = ReplicationFrame {
                        incarnation: 0,
                        from: me,
                        tick: tick_tag,
                        states: Vec::new(),
                    };
                    expected.wrong_sender += 1;
                    (&replication_channel, vec![exact(&frame)])
                }
                // An events frame from a cluster that is not a neighbour.
                7 => {
                    let mut frame = op_frame(tick_tag, vec![PhysicsOp::Wake { target }]);
                    frame.from = ClusterId::random();
                    expected.wrong_sender += 1;
                    (&events_channel, vec![wire::encode(&frame)])
                }
                // The same frame twice: the second is a replay.
                8 => {
                    let bytes = wire::encode(&op_frame(
                        tick_tag,
                        vec![PhysicsOp::SetLinvel {
                            target: EntityId::random(),
                            linvel: [0.0; 3],
                        }],
                    ));
                    expected.accepted += 1;
                    expected.ops_not_owner += 1;
                    expected.replayed += 1;
                    (&events_channel, vec![bytes.clone(), bytes])
                }
                // Tagged far ahead of where the live neighbour is (on either channel): only a
                // forger sends that, and were it taken, every honest frame after it would look
                // like a replay.
                9 => {
                    let ahead = tick_tag + 1_000_000 + noise.next() % 1_000_000;
                    expected.implausible += 1;
                    if noise.next().is_multiple_of(2) {
                        let frame = op_frame(ahead, vec![PhysicsOp::Wake { target }]);
                        (&events_channel, vec![wire::encode(&frame)])
                    } else {
                        let frame = ReplicationFrame {
                            incarnation: 0,
                            from: neighbour,
                            tick: ahead,
                            states: Vec::new(),
                        };
                        (&replication_channel, vec![exact(&frame)])
                    }
                }
                // Records that do not read: an owner or a body spec past the frame's tables.
                11 => {
                    let frame = ReplicationFrame {
                        incarnation: 0,
                        from: neighbour,
                        tick: tick_tag,
                        states: vec![ball_at(1.0, neighbour), ball_at(2.0, neighbour)],
                    };
                    let mut bytes = exact(&frame);
                    // Header 28, one owner 16, one spec 44; in a record the owner index is
                    // byte 22, the spec index bytes 23-24.
                    let records = 28 + 16 + 44;
                    bytes[records + 22] = 1 + (noise.next() % 200) as u8;
                    bytes[records + 77 + 23] = 1 + (noise.next() % 200) as u8;
                    expected.accepted += 1;
                    expected.states_rejected += 2;
                    (&replication_channel, vec![bytes])
                }
                // States no proxy may be made of.
                _ => {
                    let states: Vec<EntityState> =
                        (0..3).map(|_| bad_state(&mut noise, neighbour)).collect();
                    expected.accepted += 1;
                    expected.states_rejected += states.len() as u64;
                    let frame = ReplicationFrame {
                        incarnation: 0,
                        from: neighbour,
                        tick: tick_tag,
                        states,
                    };
                    (&replication_channel, vec![exact(&frame)])
                }
            };
            for payload in payloads {
                injector.publish(channel, &payload).expect("publish");
            }
        }
        // Redis delivers asynchronously: tick until the batch has been seen.
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            cluster.tick(|_, _| {}).expect("the cluster keeps ticking");
            let seen =
                Tally::of(&cluster.stats()).frames() + cluster.transport_stats().overflow_drops;
            if seen >= expected.frames() || Instant::now() > deadline {
                break;
            }
            std::thread::yield_now();
        }
    }

    let s = cluster.stats();
    let t = cluster.transport_stats();
    assert_eq!(t.overflow_drops, 0, "ticks kept up with the flood: {t:?}");
    assert_eq!(
        t.malformed_drops, 0,
        "the transport passed every frame on: {t:?}"
    );
    assert_eq!(
        Tally::of(&s),
        expected,
        "every frame, state and op counted under the reason it was injected for: {s:?}"
    );
    assert!(
        expected.implausible > 0 && expected.states_rejected > 0 && expected.replayed > 0,
        "every kind injected: {expected:?}"
    );
    // A refusal names the sender wherever the frame could be read (both kinds of wrong
    // sender here: a frame claiming this cluster on the neighbour's channel, a stranger's).
    let mut named = |reason: FrameRefusal| {
        cluster
            .take_events()
            .iter()
            .filter(|e| {
                matches!(e.event, ClusterEvent::FrameRefused { reason: r, from }
                    if r == reason && from.is_some())
            })
            .count() as u64
    };
    assert_eq!(named(FrameRefusal::WrongSender), s.frames_wrong_sender);
    assert_eq!(s.neighbours_lost, 0, "the neighbour stayed alive: {s:?}");
    assert_eq!(s.ops_applied, 0, "no op applied: {s:?}");
    assert_eq!(s.proxies_spawned, 0, "no bad state became a proxy: {s:?}");
    assert_eq!(cluster.sim().len(), mine.len(), "no entity added or lost");
    assert_eq!(
        snapshot(&cluster),
        before,
        "the world is bit-for-bit unchanged"
    );
}
