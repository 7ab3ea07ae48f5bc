//! seam's one world against plain Rapier on the same bodies (issue 38 item 2): a `seam` pod
//! playing every cluster of a scene (`seam node --reference`: a `Cluster` alone in its world,
//! over the in-process transport, ticked as pods tick) beside `seam-anchor`'s plain Rapier
//! world of the same bodies (what `seam capacity` measures against). The scene's scripted
//! events are left out of both (the anchor has none), so both step the same physics.
//!
//! `cargo bench -p seam-bench --bench bench_one_world`. First, per scene, 600 ticks of each
//! alternately (after 60 of warm-up) and their medians, so machine noise falls on both alike;
//! then criterion times each on its own.

// criterion_group! generates a public function without docs.
#![allow(missing_docs)]

use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use seam_anchor::PlainWorld;
use seam_bench::pod::{Part, Pod, PodSettings};
use seam_bench::scene::Scene;

const WARMUP: usize = 60;
const TICKS: usize = 600;

/// `file` (under `bench/scenes`) stacked to `layers`, without its scripted events.
fn scene(file: &str, layers: u32) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(file);
    let mut scene = seam_bench::scene::load(&path)
        .expect("a bundled scene")
        .stacked(layers)
        .expect("stacked");
    scene.events.clear();
    scene
}

fn seam_world(scene: &Scene, name: &str) -> Pod {
    let transport = format!("local?prefix=seam_bench_one_{name}_{}_", std::process::id());
    let settings = PodSettings::new(transport, format!("bench-one-{name}"));
    let mut pod = Pod::new(scene, &Part::Reference, &settings).expect("the reference pod");
    pod.tick().expect("a first tick");
    pod
}

fn plain_world(scene: &Scene) -> PlainWorld {
    let spec = seam_bench::capacity::anchor_world(scene).expect("the anchor's world");
    PlainWorld::new(&spec)
}

fn paired(scene: &Scene, name: &str) {
    let mut plain = plain_world(scene);
    let mut pod = seam_world(scene, name);
    let (rapier, seam) = seam_bench::latency::paired_medians(
        WARMUP,
        TICKS,
        || plain.step(),
        || pod.tick().expect("seam ticks"),
    );
    eprintln!(
        "one_world paired ({name}, {} bodies), {TICKS} alternating ticks after {WARMUP} warm-up: \
         plain Rapier median {:.3} ms, seam median {:.3} ms, seam / Rapier = {:.3}",
        plain.len(),
        rapier * 1e3,
        seam * 1e3,
        seam / rapier
    );
}

fn one_world(c: &mut Criterion) {
    let scenes = [
        ("grid", scene("grid.toml", 3)),
        ("piles", scene("capacity/piles.toml", 10)),
    ];
    for (name, scene) in &scenes {
        paired(scene, name);
    }
    for (name, scene) in &scenes {
        let mut group = c.benchmark_group(format!("one_world_{name}"));
        group
            .sample_size(30)
            .measurement_time(Duration::from_secs(10));
        let mut plain = plain_world(scene);
        group.bench_function("plain_rapier", |b| b.iter(|| plain.step()));
        let mut pod = seam_world(scene, name);
        group.bench_function("seam", |b| b.iter(|| pod.tick().expect("seam ticks")));
        group.finish();
    }
}

criterion_group!(benches, one_world);
criterion_main!(benches);
