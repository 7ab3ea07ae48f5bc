//! Frames on the wire and through a transport.
//!
//! `cargo bench -p seam-bench --bench bench_replication`:
//! - `op_batch`: encoding and decoding a physics-events frame of 1, 16 and 256 routed ops.
//! - `replication_10k_end_to_end`: one replication frame of 10 000 states, encoded straight into
//!   the transport's buffer, published, received, decoded from the received bytes and applied
//!   to 10 000 Fixed proxies, then the receiving world stepped — on `local` and on `shm`, both
//!   ends in this process; `apply_only`, the applying alone; and `rapier_floor`, what Rapier
//!   itself costs for the same work with no seam: 10 000 Fixed balls' poses set directly and
//!   the world stepped. The end-to-end case is judged against the floor: after the group, a
//!   paired run alternates the two (shm) and prints the ratio of their medians, which holds
//!   still on a noisy machine where the group's separate estimates drift.

// criterion_group! generates a public function without docs.
#![allow(missing_docs)]

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use seam_sim::wire::{
    self, BodySpec, ClusterId, EntityId, EntityState, PhysicsEventsFrame, PhysicsOp,
    ReplicationFrame, RoutedOp, Shape,
};
use seam_sim::{BodyRole, ClusterSim, SimConfig};
use seam_transport::Transport;

const STATES: usize = 10_000;

fn events(batch: usize) -> PhysicsEventsFrame {
    PhysicsEventsFrame {
        from: ClusterId::from_u128(1),
        tick: 7,
        published_ns: 1_000_000_000,
        ops: (0..batch)
            .map(|i| RoutedOp {
                op: PhysicsOp::Impulse {
                    target: EntityId::from_u128(i as u128 + 10),
                    impulse: [1.0, 2.0, 3.0],
                },
                issued_ns: 999_000_000 + i as u64,
                issued_tick: 7,
                forwarded: false,
            })
            .collect(),
        contacts: Vec::new(),
        impulses: Vec::new(),
    }
}

fn op_batch(c: &mut Criterion) {
    let mut group = c.benchmark_group("op_batch");
    for batch in [1usize, 16, 256] {
        let frame = events(batch);
        let bytes = wire::encode(&frame);
        let mut buffer = vec![0u8; bytes.len()];
        group.throughput(Throughput::Elements(batch as u64));
        group.bench_with_input(BenchmarkId::new("encode", batch), &batch, |b, _| {
            b.iter(|| wire::encode_into(&frame, &mut buffer).expect("fits"))
        });
        group.bench_with_input(BenchmarkId::new("decode", batch), &batch, |b, _| {
            b.iter(|| wire::decode::<PhysicsEventsFrame>(&bytes).expect("valid"))
        });
    }
    group.finish();
}

fn state(i: usize, owner: ClusterId) -> EntityState {
    let body = BodySpec::new(Shape::ball(0.5));
    EntityState {
        tick: 1,
        ..EntityState::new(EntityId::from_u128(i as u128 + 1), owner, body)
            .at([(i % 100) as f32 * 3.0, 0.0, (i / 100) as f32 * 3.0])
            .velocity([0.5, 0.0, 0.0])
    }
}

/// One receiving cluster's share of replication, end to end on one transport: a frame of
/// 10 000 states encoded into the transport's buffer, published, received, decoded from the
/// received bytes, applied to 10 000 Fixed proxies, and the world stepped.
struct EndToEnd {
    publisher: Box<dyn Transport>,
    subscriber: Box<dyn Transport>,
    channel: String,
    frame: ReplicationFrame,
    proxies: ClusterSim,
}

impl EndToEnd {
    fn new(backend: &str) -> Self {
        let owner = ClusterId::from_u128(1);
        let frame = ReplicationFrame {
            from: owner,
            tick: 1,
            states: (0..STATES).map(|i| state(i, owner)).collect(),
        };
        let url = format!("{backend}?prefix=seam_bench_repl_{}_", std::process::id());
        let publisher = seam_transport::open(&url).expect("open");
        let mut subscriber = seam_transport::open(&url).expect("open");
        let channel = seam_proxy::replication(owner);
        subscriber.subscribe(&channel).expect("subscribe");
        let mut proxies = ClusterSim::new(SimConfig::new(ClusterId::from_u128(2)));
        for state in &frame.states {
            proxies.spawn(state, BodyRole::Fixed).expect("proxy");
        }
        Self {
            publisher,
            subscriber,
            channel,
            frame,
            proxies,
        }
    }

    fn iteration(&mut self) {
        self.frame.tick += 1;
        for state in &mut self.frame.states {
            state.position[0] += 0.01;
        }
        let (frame, len) = (&self.frame, self.frame.max_encoded_len());
        self.publisher
            .publish_with(&self.channel, len, &mut |out| {
                wire::encode_into(frame, out).ok()
            })
            .expect("publish");
        let message = self
            .subscriber
            .receive_timeout(Duration::from_secs(5))
            .expect("receive")
            .expect("the frame arrives");
        let received: ReplicationFrame = wire::decode(message.payload).expect("valid");
        for state in &received.states {
            self.proxies.apply_state(state).expect("proxy update");
        }
        self.proxies.step();
    }
}

/// The floor: 10 000 Fixed balls in a plain Rapier world, each moved by setting its pose, then
/// the world stepped — what any replication onto Rapier bodies costs at least.
struct RapierFloor {
    world: rapier3d::prelude::PhysicsWorld,
    bodies: Vec<(
        rapier3d::prelude::RigidBodyHandle,
        rapier3d::prelude::Vector,
    )>,
    offset: f32,
}

impl RapierFloor {
    fn new() -> Self {
        use rapier3d::prelude::*;
        let mut world = PhysicsWorld::new();
        world.integration_parameters.dt = 1.0 / 60.0;
        let bodies = (0..STATES)
            .map(|i| {
                let at = Vector::from_array(state(i, ClusterId::from_u128(1)).position);
                let body = RigidBodyBuilder::fixed().translation(at);
                let (handle, _) = world.insert(body, ColliderBuilder::ball(0.5));
                (handle, at)
            })
            .collect();
        Self {
            world,
            bodies,
            offset: 0.0,
        }
    }

    fn iteration(&mut self) {
        self.offset += 0.01;
        for &(handle, at) in &self.bodies {
            let to = at + rapier3d::prelude::Vector::new(self.offset, 0.0, 0.0);
            self.world.bodies[handle].set_translation(to, false);
        }
        self.world.step();
    }
}

fn end_to_end(c: &mut Criterion) {
    let mut group = c.benchmark_group("replication_10k_end_to_end");
    group
        .sample_size(50)
        .measurement_time(Duration::from_secs(6));
    group.throughput(Throughput::Elements(STATES as u64));
    for backend in ["local", "shm"] {
        let mut case = EndToEnd::new(backend);
        group.bench_function(backend, |b| b.iter(|| case.iteration()));
    }
    // The last stage alone: applying the 10 000 states to the proxies.
    let mut case = EndToEnd::new("local");
    group.bench_function("apply_only", |b| {
        b.iter(|| {
            for state in &mut case.frame.states {
                state.position[0] += 0.01;
                case.proxies.apply_state(state).expect("proxy update");
            }
        })
    });
    let mut floor = RapierFloor::new();
    group.bench_function("rapier_floor", |b| b.iter(|| floor.iteration()));
    group.finish();
    paired_ratio();
}

/// Alternates shm end-to-end iterations and floor iterations and compares medians, so machine
/// noise falls on both alike; prints the ratio the target is judged by.
fn paired_ratio() {
    const WARMUP: usize = 30;
    const ROUNDS: usize = 300;
    let mut case = EndToEnd::new("shm");
    let mut floor = RapierFloor::new();
    let (seam, floor) = seam_bench::latency::paired_medians(
        WARMUP,
        ROUNDS,
        || case.iteration(),
        || floor.iteration(),
    );
    eprintln!(
        "replication_10k paired, {ROUNDS} alternating rounds after {WARMUP} warm-up: \
         end to end on shm median {:.3} ms, Rapier floor median {:.3} ms, end to end / floor = {:.2}",
        seam * 1e3,
        floor * 1e3,
        seam / floor
    );
}

criterion_group!(benches, op_batch, end_to_end);
criterion_main!(benches);
