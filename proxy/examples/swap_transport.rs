//! The same game code on every transport, chosen by URL: shared memory between processes of
//! one host (`shm`), in-process (`local`), or Redis between hosts (`redis://host:port`).
//!
//! ```sh
//! cargo run --release -p seam-proxy --example swap_transport                  # local, shm, Redis on loopback
//! cargo run --release -p seam-proxy --example swap_transport -- redis://10.0.0.5:6379
//! ```
//!
//! Two clusters split at x = 0 run in lock-step (deterministic, so every transport must give
//! the same world): west's game code fires a raycast that hits its proxy of east's crate, and
//! the push it writes is routed to east, which applies it. A transport that cannot be opened
//! (no Redis server answering) is skipped with the reason; the example fails if two transports
//! disagree.

use std::time::Duration;

use seam_proxy::prelude::*;

/// Where east's crate is, and how fast it goes, after two seconds.
type Outcome = ([f32; 3], [f32; 3]);

/// The game: the same function whatever carries the frames.
fn game(cluster: usize, context: &TickContext<'_>, physics: &mut PhysicsHandle<'_>) {
    if cluster == 0 && context.tick() == 10 {
        // West shoots east along x; the crate it hits is owned by east.
        if let Some(hit) = physics.raycast([-5.0, 0.0, 0.0], [1.0, 0.0, 0.0], 50.0, None) {
            physics
                .apply_impulse(hit.entity, [300.0, 0.0, 0.0])
                .expect("a write on a proxy is routed");
        }
    }
}

fn run(url: &str, run: &str) -> Result<Outcome, ClusterError> {
    let (west, east) = (ClusterId::named(run, "west"), ClusterId::named(run, "east"));
    let mut clusters = Vec::new();
    for (me, other) in [(west, east), (east, west)] {
        let mut config = ClusterConfig::new(me, vec![other], url);
        config.gravity = [0.0; 3];
        clusters.push(Cluster::new(config)?);
    }
    let crate_ = EntityState::new(
        EntityId::named(run, "crate"),
        east,
        BodySpec::new(Shape::cuboid(0.5, 0.5, 0.5)).density(100.0),
    )
    .at([4.0, 0.0, 0.0]);
    clusters[1].spawn_owned(&crate_, BodyRole::Dynamic)?;
    for _ in 0..120 {
        lockstep_round(&mut clusters, Duration::from_secs(5), game)?;
    }
    let state = clusters[1]
        .sim()
        .state(crate_.id)
        .expect("east owns the crate");
    Ok((state.position, state.linvel))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut urls: Vec<String> = std::env::args().skip(1).collect();
    if urls.is_empty() {
        urls = ["local", "shm", "redis://127.0.0.1:6379"]
            .map(String::from)
            .to_vec();
    }
    let mut outcomes: Vec<(String, Outcome)> = Vec::new();
    for (i, url) in urls.iter().enumerate() {
        // A run name of its own per transport: ids, and so channels, never meet.
        let name = format!("swap-{}-{i}", std::process::id());
        // On shm and local, a prefix keeps this run's services apart from others on the host.
        let url = match url.as_str() {
            "shm" | "local" => format!("{url}?prefix={name}_"),
            _ => url.clone(),
        };
        let shown = seam_transport::redact_url(&url);
        match run(&url, &name) {
            Ok((at, v)) => {
                println!(
                    "{shown:<40} crate at x = {:.4} m, moving {:.4} m/s",
                    at[0], v[0]
                );
                outcomes.push((shown, (at, v)));
            }
            Err(ClusterError::Open(e)) => println!("{shown:<40} skipped: {e}"),
            Err(e) => return Err(format!("{shown}: {e}").into()),
        }
    }
    if outcomes.windows(2).any(|w| w[0].1 != w[1].1) {
        return Err("the transports disagree: lock-step must give one world".into());
    }
    println!("same world on all {} transports run", outcomes.len());
    Ok(())
}
