//! Two clusters in one process, side by side along x with the seam at x = 0: west owns a ball
//! rolling east, east owns a crate just past the seam. The ball crosses the seam, hits the
//! crate in both worlds (each models the other's body as a proxy), and the authority policy
//! hands the ball to east once it is in east's region. Every few ticks it prints who owns the
//! ball and where both bodies are.
//!
//! ```sh
//! cargo run --release -p seam-proxy --example two_clusters
//! ```

use std::time::Duration;

use seam_proxy::prelude::*;

fn main() -> Result<(), ClusterError> {
    // Ids from names: every process of one run derives the same ones.
    let run = format!("two-clusters-{}", std::process::id());
    let (west, east) = (
        ClusterId::named(&run, "west"),
        ClusterId::named(&run, "east"),
    );
    // Each cluster's region and spread (how far past it neighbours' bodies are modelled),
    // given once: each config takes its own, its neighbours and the world map from here.
    let half = |min_x: f32, max_x: f32| Region {
        min: [min_x, -50.0, -50.0],
        max: [max_x, 50.0, 50.0],
    };
    let world = [(west, half(-50.0, 0.0), 2.0), (east, half(0.0, 50.0), 2.0)];
    // The in-process transport; "shm" for pods in separate processes, "redis://..." across
    // hosts — nothing else changes.
    let url = format!("local?prefix={run}_");
    let mut clusters = Vec::new();
    for (me, ..) in world {
        let mut config = ClusterConfig::in_world(me, &world, &url)?;
        config.gravity = [0.0; 3];
        clusters.push(Cluster::new(config)?);
    }

    let ball = EntityState::new(
        EntityId::named(&run, "ball"),
        west,
        BodySpec::new(Shape::ball(0.25)).density(500.0),
    )
    .at([-3.0, 0.0, 0.0])
    .velocity([4.0, 0.0, 0.0]);
    let crate_ = EntityState::new(
        EntityId::named(&run, "crate"),
        east,
        BodySpec::new(Shape::cuboid(0.5, 0.5, 0.5)).density(200.0),
    )
    .at([1.5, 0.0, 0.0]);
    clusters[0].spawn_owned(&ball, BodyRole::Dynamic)?;
    clusters[1].spawn_owned(&crate_, BodyRole::Dynamic)?;

    let names = ["west", "east"];
    for tick in 0..120 {
        // Both clusters tick in lock-step; game code would read, query and write here.
        lockstep_round(&mut clusters, Duration::from_secs(5), |_, _, _| {})?;
        if tick % 15 == 14 {
            let owner = clusters
                .iter()
                .position(|c| c.sim().info(ball.id).is_some_and(|i| i.owner == c.id()))
                .map_or("nobody", |i| names[i]);
            let at = |id| {
                clusters
                    .iter()
                    .find(|c| c.sim().info(id).is_some_and(|i| i.owner == c.id()))
                    .and_then(|c| c.sim().state(id))
                    .map(|s| s.position[0])
            };
            println!(
                "tick {:3}: ball owned by {owner:<6} at x = {:6.2} m, crate at x = {:5.2} m",
                tick + 1,
                at(ball.id).unwrap_or(f32::NAN),
                at(crate_.id).unwrap_or(f32::NAN),
            );
        }
    }
    Ok(())
}
