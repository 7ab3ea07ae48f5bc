//! One cluster's world: the entity-keyed `ClusterSim` tick against the same scene written on raw
//! Rapier, and `ReplicationFrame` encoding and reading in place, exact and quantized.
//!
//! `cargo bench -p seam-bench --bench bench_sim`.
//!
//! The scene: 10 000 bodies, 5 000 dynamic balls falling in a grid and 5 000 kinematic
//! (position-based) boxes moved to a new pose every tick, as proxies are. One iteration is one
//! tick: move the kinematic bodies, step. `ClusterSim` moves them through `apply_state` (state
//! validation, entity lookup); raw Rapier through stored handles. Both collect contact events.

// criterion_group! generates a public function without docs.
#![allow(missing_docs)]

use std::sync::Mutex;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use rapier3d::prelude::*;
use seam_sim::wire::{
    BodySpec, ClusterId, EntityId, EntityState, ReplicationEncoder, ReplicationFrame,
    ReplicationView, Shape, StateEncoding,
};
use seam_sim::{BodyRole, ClusterSim, SimConfig};

const BODIES: usize = 10_000;
const HERE: ClusterId = ClusterId(uuid::Uuid::from_u128(1));

fn grid(i: usize) -> [f32; 3] {
    [
        (i % 100) as f32 * 3.0,
        (i / 100 % 10) as f32 * 3.0,
        (i / 1000) as f32 * 3.0,
    ]
}

/// How dynamic and kinematic bodies are laid out in spawn order.
#[derive(Clone, Copy)]
enum Order {
    /// Dynamic, kinematic, dynamic, … (a mixed world).
    Interleaved,
    /// All kinematic first, then all dynamic (the proxies of one neighbour, spawned from one
    /// frame, then updated in that frame's order).
    Contiguous,
}

fn is_dynamic(i: usize, order: Order) -> bool {
    match order {
        Order::Interleaved => i.is_multiple_of(2),
        Order::Contiguous => i >= BODIES / 2,
    }
}

fn state(i: usize) -> EntityState {
    state_in(i, Order::Interleaved)
}

fn state_in(i: usize, order: Order) -> EntityState {
    let dynamic = is_dynamic(i, order);
    let shape = if dynamic {
        Shape::ball(0.5)
    } else {
        Shape::cuboid(0.5, 0.5, 0.5)
    };
    EntityState::new(
        EntityId::from_u128(i as u128 + 1),
        HERE,
        BodySpec::new(shape),
    )
    .at(grid(i))
}

/// Where kinematic body `i` goes at `tick`: a small circle around its grid point.
fn kinematic_target(i: usize, tick: u64) -> [f32; 3] {
    let [x, y, z] = grid(i);
    let phase = tick as f32 * 0.05 + i as f32;
    [x + 0.5 * phase.cos(), y, z + 0.5 * phase.sin()]
}

struct Raw {
    world: PhysicsWorld,
    kinematic: Vec<(usize, RigidBodyHandle)>,
    events: Collector,
    tick: u64,
}

#[derive(Default)]
struct Collector(Mutex<Vec<CollisionEvent>>);

impl EventHandler for Collector {
    fn handle_collision_event(
        &self,
        _: &RigidBodySet,
        _: &ColliderSet,
        event: CollisionEvent,
        _: Option<&ContactPair>,
    ) {
        if let Ok(mut events) = self.0.lock() {
            events.push(event);
        }
    }
    fn handle_contact_force_event(
        &self,
        _: Real,
        _: &RigidBodySet,
        _: &ColliderSet,
        _: &ContactPair,
        _: Real,
    ) {
    }
    fn handle_soft_body_tear_event(&self, _: &SoftBodySet, _: &SoftBodyTearEvent) {}
}

fn raw_world(order: Order) -> Raw {
    let mut world = PhysicsWorld::new();
    world.integration_parameters.dt = 1.0 / 60.0;
    let mut kinematic = Vec::new();
    for i in 0..BODIES {
        let s = state_in(i, order);
        let dynamic = is_dynamic(i, order);
        let body = RigidBodyBuilder::new(if dynamic {
            RigidBodyType::Dynamic
        } else {
            RigidBodyType::KinematicPositionBased
        })
        .translation(Vector::from_array(s.position))
        .user_data(s.id.as_u128());
        let collider = if dynamic {
            ColliderBuilder::ball(0.5)
        } else {
            ColliderBuilder::cuboid(0.5, 0.5, 0.5)
        }
        .density(1000.0)
        .user_data(s.id.as_u128())
        .active_events(ActiveEvents::COLLISION_EVENTS)
        .active_collision_types(
            ActiveCollisionTypes::default()
                | ActiveCollisionTypes::KINEMATIC_KINEMATIC
                | ActiveCollisionTypes::KINEMATIC_FIXED,
        );
        let (handle, _) = world.insert(body, collider);
        if !dynamic {
            kinematic.push((i, handle));
        }
    }
    Raw {
        world,
        kinematic,
        events: Collector::default(),
        tick: 0,
    }
}

fn raw_tick(raw: &mut Raw) {
    raw.tick += 1;
    for &(i, handle) in &raw.kinematic {
        let target = Vector::from_array(kinematic_target(i, raw.tick));
        raw.world.bodies[handle].set_next_kinematic_translation(target);
    }
    raw.world.step_with_events(&(), &raw.events);
    if let Ok(mut events) = raw.events.0.lock() {
        events.clear();
    }
}

fn seam_world(order: Order) -> (ClusterSim, Vec<(usize, EntityState)>) {
    let mut sim = ClusterSim::new(SimConfig::new(HERE));
    let mut kinematic = Vec::new();
    for i in 0..BODIES {
        let s = state_in(i, order);
        if is_dynamic(i, order) {
            sim.spawn(&s, BodyRole::Dynamic).expect("spawn");
        } else {
            sim.spawn(&s, BodyRole::KinematicPositionBased)
                .expect("spawn");
            kinematic.push((i, s));
        }
    }
    (sim, kinematic)
}

fn seam_tick(sim: &mut ClusterSim, kinematic: &mut [(usize, EntityState)], tick: &mut u64) {
    *tick += 1;
    for (i, state) in kinematic.iter_mut() {
        state.position = kinematic_target(*i, *tick);
        sim.apply_state(state).expect("move");
    }
    sim.step();
}

/// Alternates raw and ClusterSim ticks and compares medians, so machine noise falls on both
/// alike; prints the ratio the target is judged by.
fn paired_ratio(order: Order, name: &str) {
    const WARMUP: usize = 100;
    const TICKS: usize = 600;
    let mut raw = raw_world(order);
    let (mut sim, mut kinematic) = seam_world(order);
    let mut tick = 0;
    let (raw, seam) = seam_bench::latency::paired_medians(
        WARMUP,
        TICKS,
        || raw_tick(&mut raw),
        || seam_tick(&mut sim, &mut kinematic, &mut tick),
    );
    eprintln!(
        "sim_step paired ({name}), {TICKS} alternating ticks of {BODIES} bodies after {WARMUP} warm-up: \
         raw Rapier median {:.3} ms, ClusterSim median {:.3} ms, ClusterSim / raw = {:.3}",
        raw * 1e3,
        seam * 1e3,
        seam / raw
    );
}

fn sim_step(c: &mut Criterion) {
    paired_ratio(Order::Interleaved, "interleaved spawn order");
    paired_ratio(Order::Contiguous, "kinematic bodies spawned together");
    let mut group = c.benchmark_group("sim_step_10k");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(10));
    let mut raw = raw_world(Order::Interleaved);
    group.bench_function("raw_rapier", |b| b.iter(|| raw_tick(&mut raw)));
    let (mut sim, mut kinematic) = seam_world(Order::Interleaved);
    let mut tick = 0;
    group.bench_function("cluster_sim", |b| {
        b.iter(|| seam_tick(&mut sim, &mut kinematic, &mut tick))
    });
    group.finish();
}

fn replication_frame(c: &mut Criterion) {
    let frame = ReplicationFrame {
        incarnation: 0,
        from: HERE,
        tick: 1,
        states: (0..BODIES).map(state).collect(),
    };
    let mut group = c.benchmark_group("replication_frame_10k");
    for (name, encoding) in [
        ("exact", StateEncoding::Exact),
        ("quantized", StateEncoding::Quantized),
    ] {
        let bytes = frame.encode(encoding).expect("encodes");
        eprintln!(
            "replication frame of {BODIES} states, {name}: {} bytes, {:.1} bytes per state",
            bytes.len(),
            bytes.len() as f64 / BODIES as f64
        );
        let mut encoder = ReplicationEncoder::default();
        let mut buffer = vec![0u8; bytes.len()];
        group.bench_function(format!("encode_{name}"), |b| {
            b.iter(|| {
                encoder.prepare(&frame, encoding).expect("encodes");
                encoder.write(&frame, &mut buffer).expect("fits")
            })
        });
        // What a receiver does per frame: check it, then read every record in place.
        group.bench_function(format!("read_{name}"), |b| {
            b.iter(|| {
                let view = ReplicationView::parse(&bytes).expect("valid");
                view.states().filter(Result::is_ok).count()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, sim_step, replication_frame);
criterion_main!(benches);
