//! One cluster as a free-running process — a pod — on shared memory. Start two, one per
//! cluster, and they find each other by name:
//!
//! ```sh
//! cargo build --release -p seam-proxy --example pod
//! target/release/examples/pod west & target/release/examples/pod east; wait
//! ```
//!
//! The world is split at x = 0: west owns a ball rolling east, east owns a crate just past the
//! seam. Each pod ticks at 60 Hz on its own clock, sleeping on the transport in between, and
//! prints what it owns and what it models of the other side (a proxy). The ball crosses the
//! seam, is handed to east, and pushes the crate on. An
//! optional second argument is the run's name: pods of one run must share it, runs side by
//! side must not.

use std::sync::atomic::AtomicBool;

use seam_proxy::prelude::*;

const TICKS: u64 = 240;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let me = args.next().unwrap_or_default();
    let run = args.next().unwrap_or_else(|| "pod-example".to_owned());
    if me != "west" && me != "east" {
        return Err("usage: pod west|east [RUN]".into());
    }

    // Every pod derives the same ids and the same map from names: no coordinator.
    let (west, east) = (
        ClusterId::named(&run, "west"),
        ClusterId::named(&run, "east"),
    );
    let half = |min_x: f32, max_x: f32| Region {
        min: [min_x, -50.0, -50.0],
        max: [max_x, 50.0, 50.0],
    };
    // Each cluster's region and spread, given once: the config takes its own from here.
    let world = [(west, half(-50.0, 0.0), 2.0), (east, half(0.0, 50.0), 2.0)];
    let mine = if me == "west" { west } else { east };

    // Shared memory under this run's own prefix; "redis://host:6379" would do the same across
    // hosts, with nothing else changed.
    let url = format!("shm?prefix={run}_");
    let mut config = ClusterConfig::in_world(mine, &world, &url)?;
    config.gravity = [0.0; 3];
    let mut cluster = Cluster::new(config)?;

    let ball = EntityId::named(&run, "ball");
    let crate_ = EntityId::named(&run, "crate");
    let body = if me == "west" {
        EntityState::new(ball, west, BodySpec::new(Shape::ball(0.25)).density(500.0))
            .at([-3.0, 0.0, 0.0])
            .velocity([4.0, 0.0, 0.0])
    } else {
        EntityState::new(crate_, east, BodySpec::new(Shape::cuboid(0.5, 0.5, 0.5)))
            .at([1.5, 0.0, 0.0])
    };

    // Nothing moves until the other pod is there: tick idle (publishing, so it hears of us)
    // until its first frame has come, for at most 10 s.
    let other = cluster.config().neighbours[0];
    let stop = AtomicBool::new(false); // a signal handler would set it to stop early
    let mut waiting = Schedule::new(60.0, 600)?;
    while cluster.neighbour_status(other) != Some(NeighbourStatus::Alive) {
        if waiting.wait_for_next(&mut cluster, &stop)?.is_none() {
            return Err(
                format!("{me}: no frame from the other pod in 10 s: is it running?").into(),
            );
        }
        cluster.tick(|_, _| {})?;
    }
    cluster.spawn_owned(&body, BodyRole::Dynamic)?;
    println!(
        "{me}: met the other pod, spawned the {}",
        if me == "west" { "ball" } else { "crate" }
    );

    let mut schedule = Schedule::new(60.0, TICKS)?;
    while let Some(due) = schedule.wait_for_next(&mut cluster, &stop)? {
        // Game code reads, queries and writes here; this one only watches.
        cluster.tick(|_, _| {})?;
        if due.tick % 40 == 39 {
            let say = |id| match cluster.sim().info(id) {
                Some(_) if cluster.owns(id) => "owned here",
                Some(_) => "a proxy",
                None => "not here",
            };
            let x = |id| cluster.sim().state(id).map_or(f32::NAN, |s| s.position[0]);
            println!(
                "{me} tick {:3}: ball {} at x = {:5.2} m, crate {} at x = {:5.2} m",
                due.tick + 1,
                say(ball),
                x(ball),
                say(crate_),
                x(crate_)
            );
        }
    }
    let stats = cluster.stats();
    println!(
        "{me}: done; {} hand-offs out, {} in",
        stats.handoffs_out, stats.handoffs_in
    );
    Ok(())
}
