//! The wire format: round trips, and untrusted bytes that must never panic.

use seam_sim::wire::{
    self, BodySpec, ClusterId, ContactReport, EntityId, EntityState, PhysicsEventsFrame, PhysicsOp,
    ReplicationFrame, RoutedOp, SeamImpulseReport, Shape, WIRE_VERSION, WireError,
};

fn state(i: u32) -> EntityState {
    EntityState {
        id: EntityId::from_u128(i as u128 + 1),
        cluster_id: ClusterId::from_u128(7),
        tick: 42 + i as u64,
        epoch: 0,
        position: [i as f32, 1.5, -2.0],
        rotation: [0.0, 0.0, 0.0, 1.0],
        linvel: [0.5, 0.0, 1e3],
        angvel: [0.0, -1.0, 0.0],
        body: BodySpec {
            shape: match i % 3 {
                0 => Shape::Ball { radius: 0.5 },
                1 => Shape::Cuboid {
                    half_extents: [1.0, 2.0, 3.0],
                },
                _ => Shape::Capsule {
                    half_height: 0.9,
                    radius: 0.3,
                },
            },
            density: 1000.0,
            ccd: i.is_multiple_of(2),
            simulated: true,
        },
    }
}

fn replication() -> ReplicationFrame {
    ReplicationFrame {
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
        from: ClusterId::from_u128(9),
        tick: 100,
        published_ns: 123_456_789,
        ops: ops
            .into_iter()
            .enumerate()
            .map(|(i, op)| RoutedOp {
                op,
                issued_ns: 1000 + i as u64,
                issued_tick: 99,
                forwarded: false,
            })
            .collect(),
        contacts: vec![ContactReport {
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
    }
}

#[test]
fn frames_round_trip() {
    let frame = replication();
    let bytes = wire::encode(&frame);
    assert_eq!(bytes[0], WIRE_VERSION);
    assert_eq!(bytes.len(), wire::encoded_len(&frame));
    assert_eq!(wire::decode::<ReplicationFrame>(&bytes), Ok(frame));

    let frame = events();
    let bytes = wire::encode(&frame);
    assert_eq!(wire::decode::<PhysicsEventsFrame>(&bytes), Ok(frame));
}

#[test]
fn encode_into_a_buffer_of_exactly_the_size() {
    let frame = replication();
    let needed = wire::encoded_len(&frame);
    let mut buffer = vec![0u8; needed];
    assert_eq!(wire::encode_into(&frame, &mut buffer), Ok(needed));
    assert_eq!(
        wire::encode_into(&frame, &mut buffer[..needed - 1]),
        Err(WireError::BufferTooSmall {
            needed,
            capacity: needed - 1
        })
    );
    assert_eq!(
        wire::encode_into(&frame, &mut []),
        Err(WireError::BufferTooSmall {
            needed,
            capacity: 0
        })
    );
}

#[test]
fn framing_errors_are_named() {
    let mut bytes = wire::encode(&replication());
    assert_eq!(wire::decode::<ReplicationFrame>(&[]), Err(WireError::Empty));
    bytes[0] = 99;
    assert_eq!(
        wire::decode::<ReplicationFrame>(&bytes),
        Err(WireError::Version { found: 99 })
    );
    let mut bytes = wire::encode(&replication());
    bytes.extend_from_slice(&[1, 2, 3]);
    assert_eq!(
        wire::decode::<ReplicationFrame>(&bytes),
        Err(WireError::TrailingBytes(3))
    );
}

#[test]
fn every_truncation_is_an_error() {
    for bytes in [wire::encode(&replication()), wire::encode(&events())] {
        for cut in 0..bytes.len() {
            assert!(wire::decode::<ReplicationFrame>(&bytes[..cut]).is_err());
            assert!(wire::decode::<PhysicsEventsFrame>(&bytes[..cut]).is_err());
        }
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
        decoded += usize::from(wire::decode::<ReplicationFrame>(&bytes).is_ok());
        decoded += usize::from(wire::decode::<PhysicsEventsFrame>(&bytes).is_ok());
    }
    // Random bytes rarely make a frame; that they never panic is the point.
    assert!(decoded < 100_000);
}

#[test]
fn flipped_bits_never_panic() {
    // Every single-bit flip of both frame kinds, decoded as both kinds.
    for bytes in [wire::encode(&events()), wire::encode(&replication())] {
        for bit in 0..bytes.len() * 8 {
            let mut corrupted = bytes.clone();
            corrupted[bit / 8] ^= 1 << (bit % 8);
            let _ = wire::decode::<PhysicsEventsFrame>(&corrupted);
            let _ = wire::decode::<ReplicationFrame>(&corrupted);
        }
    }
}

#[test]
fn max_encoded_len_bounds_every_frame() {
    let mut frame = replication();
    for state in &mut frame.states {
        state.tick = u64::MAX;
    }
    assert!(wire::encoded_len(&frame) <= frame.max_encoded_len());
    frame.states.clear();
    frame.tick = u64::MAX;
    assert!(wire::encoded_len(&frame) <= frame.max_encoded_len());
}
