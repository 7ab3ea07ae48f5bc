//! A lock-step split judged as `seam run` judges free-running pods: by where its bodies end.
//!
//! `seam compare` judges lock-step clusters at every tick; `seam run` judges pods at their last
//! tick only. This runs a scene split in lock-step (the trial's ids and default settings) and as
//! one world, tick for tick, and prints the RMS and largest distance between the two at the
//! last tick, so a free-running figure can be set beside lock-step's on the same basis:
//!
//! ```sh
//! cargo run --release -p seam-bench --example final_tick -- bench/scenes/seam-stack.toml
//! ```

use std::collections::HashMap;
use std::time::Duration;

use seam_bench::accuracy::TrialSettings;
use seam_bench::pod::{Part, Pod, PodSettings};

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: final_tick SCENE.toml");
        std::process::exit(2);
    };
    let scene = seam_bench::scene::load(std::path::Path::new(&path))
        .unwrap_or_else(|e| panic!("{path}: {e}"));
    let settings = TrialSettings::default();
    let scene = settings.apply(scene);
    let pod_settings = |transport: &str| PodSettings {
        authority: settings.authority.mode(),
        ..PodSettings::new(transport, "seam-trial")
    };
    let prefix = format!("local?prefix=final_tick_{}_", std::process::id());
    let mut reference = Pod::new(
        &scene,
        &Part::Reference,
        &pod_settings(&format!("{prefix}ref_")),
    )
    .expect("one world");
    let mut pods: Vec<Pod> = (scene.clusters.iter())
        .map(|c| {
            let part = Part::Cluster(c.name.clone());
            Pod::new(&scene, &part, &pod_settings(&format!("{prefix}split_"))).expect("cluster")
        })
        .collect();
    let timeout = Duration::from_secs(10);
    for _ in 0..scene.ticks {
        reference.tick().expect("one world ticks");
        for pod in pods.iter_mut() {
            pod.begin_lockstep(timeout).expect("begins");
        }
        for pod in pods.iter_mut() {
            pod.finish_lockstep(timeout).expect("finishes");
        }
    }
    let truth: HashMap<_, _> = reference.simulated_positions().into_iter().collect();
    let (mut squares, mut bodies, mut largest) = (0.0f64, 0u64, 0.0f64);
    for (id, at) in pods.iter().flat_map(|p| p.simulated_positions()) {
        let Some(true_at) = truth.get(&id) else {
            continue;
        };
        let d2: f64 = (0..3).map(|k| f64::from(at[k] - true_at[k]).powi(2)).sum();
        squares += d2;
        bodies += 1;
        largest = largest.max(d2.sqrt());
    }
    let rms = (squares / bodies.max(1) as f64).sqrt();
    println!(
        "{}: lock-step split against one world at its last tick (tick {}): RMS {rms:.4} m, max {largest:.4} m over {bodies} bodies",
        scene.name, scene.ticks
    );
}
