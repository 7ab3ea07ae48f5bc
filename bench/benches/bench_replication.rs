//! Frames on the wire and through a transport.
//!
//! `cargo bench -p seam-bench --bench bench_replication`:
//! - `op_batch`: encoding and decoding a physics-events frame of 1, 16 and 256 routed ops.
//! - `replication_10k_end_to_end`: one replication frame of 10 000 states, encoded straight into
//!   the transport's buffer, published, received, its records read in place from the received
//!   bytes and applied to 10 000 Fixed proxies, then the receiving world stepped — on `local`
//!   and on `shm`, both ends in this process; `shm_quantized`, the same with quantized states;
//!   `shm_interest_10pct`, a receiver modelling one entity in ten; `apply_only`, the applying alone; and `rapier_floor`, what Rapier
//!   itself costs for the same work with no seam: 10 000 Fixed balls' poses set directly and
//!   the world stepped; `rapier_floor_kinematic` and `rapier_floor_parentless`, the same with
//!   position-based kinematic bodies moved by `set_next_kinematic_position` and with colliders
//!   that have no body. The end-to-end case is judged against the floor: after the group, a
//!   paired run alternates the two (shm) and prints the ratio of their medians, which holds
//!   still on a noisy machine where the group's separate estimates drift; a second paired run
//!   sets one entity in ten modelled against all modelled.

// criterion_group! generates a public function without docs.
#![allow(missing_docs)]

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use seam_sim::wire::{
    self, BodySpec, ClusterId, EntityId, EntityState, PhysicsEventsFrame, PhysicsOp,
    ReplicationEncoder, ReplicationFrame, ReplicationView, RoutedOp, Shape, Stage, StateEncoding,
};
use seam_sim::{BodyRole, ClusterSim, SimConfig};
use seam_transport::Transport;

const STATES: usize = 10_000;

fn events(batch: usize) -> PhysicsEventsFrame {
    PhysicsEventsFrame {
        incarnation: 0,
        from: ClusterId::from_u128(1),
        tick: 7,
        stage: Stage::AfterStep,
        published_ns: 1_000_000_000,
        ops: (0..batch)
            .map(|i| RoutedOp {
                op: PhysicsOp::Impulse {
                    target: EntityId::from_u128(i as u128 + 10),
                    impulse: [1.0, 2.0, 3.0],
                },
                seq: 1_796_000_000_000_000 + i as u64,
                issuer: None,
                issued_ns: 999_000_000 + i as u64,
                issued_tick: 7,
                age_ticks: 0,
            })
            .collect(),
        acks: Vec::new(),
        contacts: Vec::new(),
        impulses: Vec::new(),
        own_writes: Vec::new(),
        leaving: false,
        unmodelled: Vec::new(),
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
/// 10 000 states encoded into the transport's buffer, published, received, its records read in
/// place from the received bytes (on shm, the shared-memory sample), applied to the proxies,
/// and the world stepped. The receiver models every `1 / modelled_every`-th entity: a record
/// of an entity it models is read and applied; any other has its pose read, as a receiver
/// must to know whether the entity came into its interest, and is passed over.
struct EndToEnd {
    publisher: Box<dyn Transport>,
    subscriber: Box<dyn Transport>,
    channel: String,
    frame: ReplicationFrame,
    encoder: ReplicationEncoder,
    encoding: StateEncoding,
    proxies: ClusterSim,
}

impl EndToEnd {
    fn new(backend: &str, encoding: StateEncoding, modelled_every: usize) -> Self {
        let owner = ClusterId::from_u128(1);
        let frame = ReplicationFrame {
            incarnation: 0,
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
        for state in frame.states.iter().step_by(modelled_every) {
            proxies.spawn(state, BodyRole::Fixed).expect("proxy");
        }
        Self {
            publisher,
            subscriber,
            channel,
            frame,
            encoder: ReplicationEncoder::default(),
            encoding,
            proxies,
        }
    }

    fn iteration(&mut self) {
        self.frame.tick += 1;
        for state in &mut self.frame.states {
            state.position[0] += 0.01;
        }
        let frame = &self.frame;
        let len = self.encoder.prepare(frame, self.encoding).expect("encodes");
        let encoder = &self.encoder;
        self.publisher
            .publish_with(&self.channel, len, &mut |out| {
                encoder.write(frame, out).ok()
            })
            .expect("publish");
        let message = self
            .subscriber
            .receive_timeout(Duration::from_secs(5))
            .expect("receive")
            .expect("the frame arrives");
        let view = ReplicationView::parse(message.payload).expect("valid");
        let mut interesting = 0.0;
        for i in 0..view.len() {
            let state = view.state(i).expect("valid");
            // One lookup: a state of an entity not modelled here is refused as unknown.
            if self.proxies.apply_state(&state).is_err() {
                interesting += state.position[0];
            }
        }
        std::hint::black_box(interesting);
        self.proxies.step();
    }
}

/// How a floor case moves its 10 000 stand-ins (issue 16, item 5: which proxy update is
/// cheapest in Rapier itself).
#[derive(Clone, Copy)]
enum ProxyUpdate {
    /// A Fixed body set with `set_translation` (what seam's Fixed proxies do).
    FixedPose,
    /// A position-based kinematic body given `set_next_kinematic_position`.
    KinematicNextPose,
    /// A collider with no body, set with `Collider::set_translation`.
    Parentless,
}

/// The floor: 10 000 balls in a plain Rapier world, each moved as `update` says, then the world
/// stepped — what any replication onto Rapier costs at least.
struct RapierFloor {
    world: rapier3d::prelude::PhysicsWorld,
    bodies: Vec<(StandIn, rapier3d::prelude::Vector)>,
    offset: f32,
}

/// One stand-in, as its case made it.
#[derive(Clone, Copy)]
enum StandIn {
    Fixed(rapier3d::prelude::RigidBodyHandle),
    Kinematic(rapier3d::prelude::RigidBodyHandle),
    Parentless(rapier3d::prelude::ColliderHandle),
}

impl RapierFloor {
    fn new(update: ProxyUpdate) -> Self {
        use rapier3d::prelude::*;
        let mut world = PhysicsWorld::new();
        world.integration_parameters.dt = 1.0 / 60.0;
        let bodies = (0..STATES)
            .map(|i| {
                let at = Vector::from_array(state(i, ClusterId::from_u128(1)).position);
                let collider = ColliderBuilder::ball(0.5);
                let handle = match update {
                    ProxyUpdate::FixedPose => {
                        let body = RigidBodyBuilder::fixed().translation(at);
                        StandIn::Fixed(world.insert(body, collider).0)
                    }
                    ProxyUpdate::KinematicNextPose => {
                        let body = RigidBodyBuilder::kinematic_position_based().translation(at);
                        StandIn::Kinematic(world.insert(body, collider).0)
                    }
                    ProxyUpdate::Parentless => {
                        StandIn::Parentless(world.colliders.insert(collider.translation(at)))
                    }
                };
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
        use rapier3d::prelude::{Pose, Vector};
        self.offset += 0.01;
        for &(handle, at) in &self.bodies {
            let to = at + Vector::new(self.offset, 0.0, 0.0);
            match handle {
                StandIn::Fixed(h) => self.world.bodies[h].set_translation(to, false),
                StandIn::Kinematic(h) => {
                    self.world.bodies[h].set_next_kinematic_position(Pose::from_translation(to))
                }
                StandIn::Parentless(h) => self.world.colliders[h].set_translation(to),
            }
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
        let mut case = EndToEnd::new(backend, StateEncoding::Exact, 1);
        group.bench_function(backend, |b| b.iter(|| case.iteration()));
    }
    let mut case = EndToEnd::new("shm", StateEncoding::Quantized, 1);
    group.bench_function("shm_quantized", |b| b.iter(|| case.iteration()));
    // A receiver whose interest holds one entity in ten.
    let mut case = EndToEnd::new("shm", StateEncoding::Exact, 10);
    group.bench_function("shm_interest_10pct", |b| b.iter(|| case.iteration()));
    // The last stage alone: applying the 10 000 states to the proxies.
    let mut case = EndToEnd::new("local", StateEncoding::Exact, 1);
    group.bench_function("apply_only", |b| {
        b.iter(|| {
            for state in &mut case.frame.states {
                state.position[0] += 0.01;
                case.proxies.apply_state(state).expect("proxy update");
            }
        })
    });
    for (name, update) in [
        ("rapier_floor", ProxyUpdate::FixedPose),
        ("rapier_floor_kinematic", ProxyUpdate::KinematicNextPose),
        ("rapier_floor_parentless", ProxyUpdate::Parentless),
    ] {
        let mut floor = RapierFloor::new(update);
        group.bench_function(name, |b| b.iter(|| floor.iteration()));
    }
    group.finish();
    paired_ratio();
}

/// Alternates shm end-to-end iterations and floor iterations and compares medians, so machine
/// noise falls on both alike; prints the ratios the targets are judged by: all modelled
/// against the floor, and a receiver modelling one entity in ten against all modelled.
fn paired_ratio() {
    let mut all = EndToEnd::new("shm", StateEncoding::Exact, 1);
    let mut floor = RapierFloor::new(ProxyUpdate::FixedPose);
    paired(
        ("end to end on shm", || all.iteration()),
        ("Rapier floor", || floor.iteration()),
    );
    let mut tenth = EndToEnd::new("shm", StateEncoding::Exact, 10);
    paired(
        ("1 entity in 10 modelled", || tenth.iteration()),
        ("all modelled", || all.iteration()),
    );
}

/// Alternates `a` and `b` and prints their medians and the ratio of `a` to `b`.
fn paired((a_name, a): (&str, impl FnMut()), (b_name, b): (&str, impl FnMut())) {
    const WARMUP: usize = 30;
    const ROUNDS: usize = 300;
    let (a_s, b_s) = seam_bench::latency::paired_medians(WARMUP, ROUNDS, a, b);
    eprintln!(
        "replication_10k paired, {ROUNDS} alternating rounds after {WARMUP} warm-up: \
         {a_name} median {:.3} ms, {b_name} median {:.3} ms, {a_name} / {b_name} = {:.2}",
        a_s * 1e3,
        b_s * 1e3,
        a_s / b_s
    );
}

criterion_group!(benches, op_batch, end_to_end);
criterion_main!(benches);
