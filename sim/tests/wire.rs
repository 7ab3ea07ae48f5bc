//! The wire format: round trips, and untrusted bytes that must never panic.

use seam_sim::wire::{
    self, BodySpec, ClusterId, ContactReport, DeltaBase, EntityId, EntityState, OpAck,
    PhysicsEventsFrame, PhysicsOp, ReplicationEncoder, ReplicationFrame, ReplicationView, RoutedOp,
    SeamImpulseReport, Shape, Stage, StateEncoding, WIRE_VERSION, WireError,
};

const ENCODINGS: [StateEncoding; 2] = [StateEncoding::Exact, StateEncoding::Quantized];

fn encode(frame: &ReplicationFrame) -> Vec<u8> {
    frame.encode(StateEncoding::Exact).expect("encodes")
}

fn state(i: u32) -> EntityState {
    EntityState {
        id: EntityId::from_u128(i as u128 + 1),
        cluster_id: ClusterId::from_u128(7),
        tick: 42 - u64::from(i),
        epoch: 0,
        position: [i as f32, 1.5, -2.0],
        rotation: [0.0, 0.0, 0.0, 1.0],
        linvel: [0.5, 0.0, 1e3],
        angvel: [0.0, -1.0, 0.0],
        body: BodySpec::new(match i % 4 {
            0 => Shape::Ball { radius: 0.5 },
            1 => Shape::Cuboid {
                half_extents: [1.0, 2.0, 3.0],
            },
            2 => Shape::Capsule {
                half_height: 0.9,
                radius: 0.3,
            },
            _ => Shape::Catalog {
                id: seam_sim::wire::ShapeId(0x0123_4567_89ab_cdef),
                bound: 1.25,
            },
        })
        .ccd(i.is_multiple_of(2))
        .friction(0.1 * (i % 4) as f32)
        .restitution(if i % 4 == 1 { 0.8 } else { 0.0 })
        .damping(0.01 * (i % 4) as f32, 0.5)
        .groups(1 << (i % 4), !0 ^ (1 << (i % 4)))
        .sensor(i % 4 == 2),
    }
}

fn replication() -> ReplicationFrame {
    ReplicationFrame {
        incarnation: 0,
        from: ClusterId::from_u128(7),
        tick: 42,
        states: (0..20).map(state).collect(),
    }
}

fn events() -> PhysicsEventsFrame {
    let target = EntityId::from_u128(3);
    let ops = vec![
        PhysicsOp::Impulse {
            target,
            impulse: [1.0, 2.0, 3.0],
        },
        PhysicsOp::Force {
            target,
            force: [0.0, 9.0, 0.0],
        },
        PhysicsOp::TorqueImpulse {
            target,
            torque_impulse: [0.1, 0.0, 0.0],
        },
        PhysicsOp::SetTranslation {
            target,
            translation: [5.0, 5.0, 5.0],
        },
        PhysicsOp::SetLinvel {
            target,
            linvel: [0.0, 0.0, -1.0],
        },
        PhysicsOp::SetAngvel {
            target,
            angvel: [0.0, 3.0, 0.0],
        },
        PhysicsOp::Wake { target },
        PhysicsOp::Sleep { target },
    ];
    PhysicsEventsFrame {
        incarnation: 0,
        from: ClusterId::from_u128(9),
        tick: 100,
        stage: Stage::AfterStep,
        published_ns: 123_456_789,
        ops: ops
            .into_iter()
            .enumerate()
            .map(|(i, op)| RoutedOp {
                op,
                seq: 1_796_000_000_000_000 + i as u64,
                issuer: (i % 2 == 1).then(|| ClusterId::from_u128(11)),
                issued_ns: 1000 + i as u64,
                issued_tick: 99,
                age_ticks: i as u32,
            })
            .collect(),
        acks: vec![
            OpAck {
                seq: 1_796_000_000_000_007,
                more: 15,
                issuer: None,
                done: true,
            },
            OpAck {
                seq: 12,
                more: 0,
                issuer: Some(ClusterId::from_u128(11)),
                done: false,
            },
        ],
        contacts: vec![ContactReport {
            seq: 1_700_000_000_000_003,
            age_ticks: 11,
            a: target,
            b: EntityId::from_u128(4),
            started: true,
            tick: 99,
            impulse: [0.5, -1.0, 2.0],
            normal: [0.0, 0.0, 1.0],
        }],
        impulses: vec![SeamImpulseReport {
            own: EntityId::from_u128(5),
            other: target,
            impulse: [-3.0, 0.25, 0.0],
            tick: 99,
        }],
        own_writes: Vec::new(),
        leaving: true,
        unmodelled: Vec::new(),
    }
}

#[test]
fn frames_round_trip() {
    let frame = replication();
    let bytes = encode(&frame);
    assert_eq!(bytes[0], WIRE_VERSION);
    assert_eq!(Ok(bytes.len()), frame.encoded_len(StateEncoding::Exact));
    assert_eq!(ReplicationFrame::decode(&bytes), Ok(frame));

    let frame = events();
    let bytes = wire::encode(&frame);
    assert_eq!(wire::decode::<PhysicsEventsFrame>(&bytes), Ok(frame));
}

#[test]
fn quantized_states_come_back_within_their_resolution() {
    let mut frame = replication();
    for (i, state) in frame.states.iter_mut().enumerate() {
        let angle = i as f32 * 0.37;
        state.rotation = [0.0, (angle / 2.0).sin(), 0.0, (angle / 2.0).cos()];
        state.position = [i as f32 * 13.3791, -0.000_37, 4_321.123_4];
    }
    let bytes = frame.encode(StateEncoding::Quantized).expect("encodes");
    let back = ReplicationFrame::decode(&bytes).expect("decodes");
    assert_eq!((back.from, back.tick), (frame.from, frame.tick));
    for (sent, got) in frame.states.iter().zip(&back.states) {
        assert_eq!(
            (got.id, got.cluster_id, got.tick, got.epoch, got.body),
            (sent.id, sent.cluster_id, sent.tick, sent.epoch, sent.body)
        );
        for k in 0..3 {
            assert!(
                (got.position[k] - sent.position[k]).abs() <= 0.000_5,
                "{got:?}"
            );
            let v = sent.linvel[k];
            assert!((got.linvel[k] - v).abs() <= v.abs() / 2048.0, "{got:?}");
        }
        // Rotation angle from the quaternions' difference (an f32 arc cosine of their dot
        // product is too coarse to judge 2e-4 rad); the largest component is sent positive.
        let dot: f32 = got
            .rotation
            .iter()
            .zip(&sent.rotation)
            .map(|(a, b)| a * b)
            .sum();
        let sign = dot.signum();
        let d: f32 = got
            .rotation
            .iter()
            .zip(&sent.rotation)
            .map(|(a, b)| (a - sign * b).powi(2))
            .sum();
        assert!(4.0 * (d.sqrt() / 2.0).asin() < 2e-4, "{got:?}");
    }
}

#[test]
fn a_state_costs_its_record_and_the_tables_are_shared() {
    let frame = replication();
    // 20 states of one owner and four specs (four shapes, each with its material).
    for (encoding, record) in [(StateEncoding::Exact, 77), (StateEncoding::Quantized, 55)] {
        let len = frame.encoded_len(encoding).expect("encodes");
        assert_eq!(len, 28 + 16 + 4 * 44 + 20 * record);
        assert_eq!(encoding.record_len(), record);
    }
}

#[test]
fn encode_into_a_buffer_of_exactly_the_size() {
    let frame = replication();
    for encoding in ENCODINGS {
        let needed = frame.encoded_len(encoding).expect("encodes");
        let mut buffer = vec![0u8; needed];
        assert_eq!(frame.encode_into(encoding, &mut buffer), Ok(needed));
        assert_eq!(
            frame.encode_into(encoding, &mut buffer[..needed - 1]),
            Err(WireError::BufferTooSmall {
                needed,
                capacity: needed - 1
            })
        );
        assert_eq!(
            frame.encode_into(encoding, &mut []),
            Err(WireError::BufferTooSmall {
                needed,
                capacity: 0
            })
        );
    }
}

#[test]
fn framing_errors_are_named() {
    let mut bytes = encode(&replication());
    assert_eq!(ReplicationFrame::decode(&[]), Err(WireError::Empty));
    bytes[0] = 99;
    assert_eq!(
        ReplicationFrame::decode(&bytes),
        Err(WireError::Version { found: 99 })
    );
    let mut bytes = encode(&replication());
    bytes.extend_from_slice(&[1, 2, 3]);
    assert_eq!(
        ReplicationFrame::decode(&bytes),
        Err(WireError::TrailingBytes(3))
    );
}

#[test]
fn a_bad_record_is_an_error_in_its_place_and_the_others_read() {
    let frame = replication();
    let mut bytes = encode(&frame);
    // Header 28, one owner 16, four specs 176; record 5's owner index is at offset 22.
    let record = |i: usize| 28 + 16 + 176 + i * 77;
    bytes[record(5) + 22] = 9;
    // Record 7's spec index points past the table.
    bytes[record(7) + 23] = 200;
    let view = ReplicationView::parse(&bytes).expect("the frame's shape is sound");
    for i in 0..view.len() {
        match i {
            5 | 7 => assert!(view.state(i).is_err(), "record {i}"),
            _ => assert_eq!(view.state(i), Ok(frame.states[i])),
        }
    }
    assert!(
        ReplicationFrame::decode(&bytes).is_err(),
        "decoding whole fails"
    );
}

#[test]
fn too_many_owners_is_an_error_not_a_panic() {
    let mut frame = replication();
    frame.states = (0..300u32)
        .map(|i| EntityState {
            cluster_id: ClusterId::from_u128(1000 + u128::from(i)),
            ..state(0)
        })
        .collect();
    assert!(frame.encode(StateEncoding::Exact).is_err());
}

#[test]
fn every_truncation_is_an_error() {
    for encoding in ENCODINGS {
        let bytes = replication().encode(encoding).expect("encodes");
        for cut in 0..bytes.len() {
            assert!(ReplicationFrame::decode(&bytes[..cut]).is_err());
        }
    }
    let bytes = wire::encode(&events());
    for cut in 0..bytes.len() {
        assert!(wire::decode::<PhysicsEventsFrame>(&bytes[..cut]).is_err());
    }
}

/// A small deterministic generator (xorshift), so failures reproduce.
struct Bytes(u64);
impl Bytes {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

#[test]
fn random_bytes_never_panic() {
    let mut rng = Bytes(0x5EA4_5EA4_5EA4_5EA4);
    let mut decoded = 0;
    for _ in 0..100_000 {
        let len = (rng.next() % 200) as usize;
        let mut bytes: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
        if let Some(first) = bytes.first_mut() {
            *first = WIRE_VERSION; // get past the version check most of the time
        }
        decoded += usize::from(ReplicationFrame::decode(&bytes).is_ok());
        decoded += usize::from(wire::decode::<PhysicsEventsFrame>(&bytes).is_ok());
    }
    // Random bytes rarely make a frame; that they never panic is the point.
    assert!(decoded < 100_000);
}

#[test]
fn flipped_bits_never_panic() {
    // Every single-bit flip of both frame kinds, decoded as both kinds.
    let frames = [
        wire::encode(&events()),
        encode(&replication()),
        replication()
            .encode(StateEncoding::Quantized)
            .expect("encodes"),
    ];
    for bytes in frames {
        for bit in 0..bytes.len() * 8 {
            let mut corrupted = bytes.clone();
            corrupted[bit / 8] ^= 1 << (bit % 8);
            let _ = wire::decode::<PhysicsEventsFrame>(&corrupted);
            if let Ok(view) = ReplicationView::parse(&corrupted) {
                // Every record reads or is an error; none panics.
                let _ = view.states().count();
            }
        }
    }
}

#[test]
fn max_encoded_len_bounds_every_frame() {
    let mut frame = replication();
    // Every state of its own spec and owner: the largest tables a frame can have.
    for (i, state) in frame.states.iter_mut().enumerate() {
        state.body.density = 1.0 + i as f32;
        state.cluster_id = ClusterId::from_u128(100 + i as u128);
    }
    for encoding in ENCODINGS {
        assert!(frame.encoded_len(encoding).expect("encodes") <= frame.max_encoded_len());
    }
    frame.states.clear();
    assert!(frame.encoded_len(StateEncoding::Exact).expect("encodes") <= frame.max_encoded_len());
}

/// A delta frame: the states it lists, and its keyframe's tick, size and unchanged bits, read
/// back as written; every truncation of it is an error; a bitmap too short for the keyframe is
/// refused when encoding.
#[test]
fn delta_frames_carry_their_keyframe_and_unchanged_bits() {
    let frame = ReplicationFrame {
        states: (0..3).map(state).collect(),
        ..replication()
    };
    // A keyframe of 20 states, of which 0, 2, 9 and 19 are unchanged.
    let unchanged = [0b0000_0101u8, 0b0000_0010, 0b0000_1000];
    let base = DeltaBase {
        key_tick: 30,
        key_states: 20,
        unchanged: &unchanged,
    };
    for encoding in ENCODINGS {
        let mut encoder = ReplicationEncoder::default();
        let len = encoder
            .prepare_delta(&frame, encoding, base)
            .expect("prepares");
        let mut bytes = vec![0; len];
        assert_eq!(encoder.write(&frame, &mut bytes), Ok(len));
        let view = ReplicationView::parse(&bytes).expect("parses");
        let delta = view.delta().expect("a delta frame");
        assert_eq!((delta.key_tick, delta.key_states), (30, 20));
        let marked: Vec<usize> = (0..24).filter(|&j| delta.is_unchanged(j)).collect();
        assert_eq!(marked, vec![0, 2, 9, 19]);
        assert_eq!(delta.unchanged_count(), 4);
        assert_eq!(view.len(), 3);
        assert_eq!(view.id(2), Some(frame.states[2].id));
        for cut in 0..bytes.len() {
            assert!(
                ReplicationView::parse(&bytes[..cut]).is_err(),
                "cut at {cut}"
            );
        }
        // A whole frame from the same encoder is not a delta frame.
        let whole = frame.encode(encoding).expect("encodes");
        assert!(
            ReplicationView::parse(&whole)
                .expect("parses")
                .delta()
                .is_none()
        );
    }
    let short = DeltaBase {
        unchanged: &unchanged[..2],
        ..base
    };
    assert!(
        ReplicationEncoder::default()
            .prepare_delta(&frame, StateEncoding::Exact, short)
            .is_err()
    );
}

/// How the owner moves a body travels with its spec, `kinematic` included (a platform's
/// proxies move with it, and a new owner keeps it kinematic); a spec that claims both
/// simulated and kinematic is malformed, an error for the states that use it.
#[test]
fn a_body_motion_round_trips_and_both_flags_are_malformed() {
    use seam_sim::wire::Motion;
    let mut frame = ReplicationFrame {
        incarnation: 0,
        from: ClusterId::from_u128(7),
        tick: 42,
        states: vec![state(0), state(3), state(6)],
    };
    for (s, motion) in
        frame
            .states
            .iter_mut()
            .zip([Motion::Simulated, Motion::Kinematic, Motion::Still])
    {
        s.body.motion = motion;
    }
    let mut bytes = encode(&frame);
    assert_eq!(ReplicationFrame::decode(&bytes), Ok(frame.clone()));
    // Header 28, one owner 16; the spec table follows, the kinematic body's second: flags at
    // byte 1 of each 44-byte spec.
    let flags = 28 + 16 + 44 + 1;
    assert_eq!(
        bytes[flags] & 6,
        4,
        "the kinematic spec has the kinematic bit only"
    );
    bytes[flags] |= 2;
    let view = ReplicationView::parse(&bytes).expect("the frame's shape is sound");
    assert!(view.state(1).is_err(), "both bits: malformed");
    assert_eq!(view.state(0), Ok(frame.states[0]));
}
