//! The proxy layer's cost per tick: cluster B's tick while its neighbour A owns 10 000 moving
//! entities, with B's region admitting 0, 1 000 or all 10 000 of them as proxies.
//!
//! `cargo bench -p seam-bench --bench bench_proxy`. The two clusters run in lock-step in this
//! process over the in-process transport (`local`); only B's tick is timed: draining A's
//! replication frame (10 000 states, ~1 MB), reconciling its proxies, user code (none), step,
//! publish.

// criterion_group! generates a public function without docs.
#![allow(missing_docs)]

use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use seam_proxy::{Cluster, ClusterConfig, Region};
use seam_sim::BodyRole;
use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, Shape};

const ENTITIES: usize = 10_000;
const TIMEOUT: Duration = Duration::from_secs(10);

fn position(i: usize) -> [f32; 3] {
    [(i % 100) as f32 * 3.0, 0.0, (i / 100) as f32 * 3.0]
}

/// A with 10 000 entities, B whose region holds the first `proxies` of them.
fn scene(proxies: usize) -> Vec<Cluster> {
    let (a, b) = (ClusterId::random(), ClusterId::random());
    let url = format!(
        "local?prefix=seam_bench_proxy_{}_{proxies}_",
        std::process::id()
    );
    let mut config_a = ClusterConfig::new(a, vec![b], &url);
    config_a.gravity = [0.0; 3];
    let mut config_b = ClusterConfig::new(b, vec![a], &url);
    config_b.gravity = [0.0; 3];
    // Rows of 100 along x, 3 m apart in z: the first `proxies` lie below z = rows × 3.
    let rows = proxies / 100;
    config_b.region = Region {
        min: [-10.0, -10.0, -10.0],
        max: [1000.0, 10.0, rows as f32 * 3.0 - 1.5],
    };
    let mut a = Cluster::new(config_a).expect("A");
    let b = Cluster::new(config_b).expect("B");
    for i in 0..ENTITIES {
        let body = BodySpec::new(Shape::ball(0.5));
        let state = EntityState::new(EntityId::from_u128(i as u128 + 1), a.id(), body)
            .at(position(i))
            // Slow drift along x, so proxies move every tick and nothing falls asleep.
            .velocity([0.5, 0.0, 0.0]);
        a.spawn_owned(&state, BodyRole::Dynamic).expect("spawn");
    }
    vec![a, b]
}

fn proxy_tick(c: &mut Criterion) {
    let mut group = c.benchmark_group("proxy_tick_10k_neighbour_entities");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(8));
    for proxies in [0, 1_000, 10_000] {
        let mut clusters = scene(proxies);
        for _ in 0..3 {
            for cluster in &mut clusters {
                cluster.tick_lockstep(TIMEOUT, |_, _| {}).expect("warm-up");
            }
        }
        let modelled = clusters[1].sim().len();
        eprintln!("proxy_tick: B models {modelled} proxies of A's {ENTITIES} entities");
        group.bench_with_input(
            BenchmarkId::new("proxies", proxies),
            &proxies,
            |bench, _| {
                bench.iter_custom(|iterations| {
                    let mut b_time = Duration::ZERO;
                    for _ in 0..iterations {
                        clusters[0].tick_lockstep(TIMEOUT, |_, _| {}).expect("A");
                        let start = Instant::now();
                        clusters[1].tick_lockstep(TIMEOUT, |_, _| {}).expect("B");
                        b_time += start.elapsed();
                    }
                    b_time
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, proxy_tick);
criterion_main!(benches);
