//! A push routed to another owner acts as if applied on the tick it was issued: it reaches
//! the owner a tick later (lock-step), and the owner adds back the motion the body missed in
//! that tick, so a body in free flight ends where one world has it. A body touching something
//! is pushed late without the catch-up: what it would have met in the missed tick with its new
//! velocity cannot be replayed.

use std::time::Duration;

use seam_proxy::{AuthorityMode, Cluster, ClusterConfig, lockstep_round};
use seam_sim::wire::{ClusterId, EntityState};
use seam_sim::{BodyRole, ClusterSim, LocalOnly, SimConfig};
use seam_tests::ball_at;

const PUSH_AT: u64 = 5;
const ROUNDS: u64 = 30;
const IMPULSE: [f32; 3] = [40.0, 0.0, 25.0];

/// Where one world has `ball` after `ROUNDS` steps with the push given in user code at tick
/// `PUSH_AT`, zero gravity.
fn one_world(ball: &EntityState) -> [f32; 3] {
    let me = ball.cluster_id;
    let mut config = SimConfig::new(me);
    config.gravity = [0.0; 3];
    let mut sim = ClusterSim::new(config);
    sim.spawn(ball, BodyRole::Dynamic).expect("spawn");
    for tick in 0..ROUNDS {
        sim.run_user(&mut LocalOnly, |context, physics| {
            if context.tick() == PUSH_AT {
                physics.apply_impulse(ball.id, IMPULSE).map(|_| ())
            } else {
                Ok(())
            }
        })
        .expect("user");
        sim.step();
        assert_eq!(sim.tick(), tick + 1);
    }
    sim.state(ball.id).expect("ball").position
}

/// A issues the push on B's ball at `PUSH_AT`; where B has the ball after `ROUNDS` rounds.
fn split(ball: &EntityState, a: ClusterId, b: ClusterId) -> ([f32; 3], u64) {
    let url = format!("local?prefix=seam_pushes_{}_{}_", std::process::id(), b);
    let mut clusters: Vec<Cluster> = [(a, b), (b, a)]
        .into_iter()
        .map(|(me, other)| {
            let mut config = ClusterConfig::new(me, vec![other], &url);
            config.gravity = [0.0; 3];
            config.authority = AuthorityMode::Scripted;
            Cluster::new(config).expect("cluster")
        })
        .collect();
    clusters[1]
        .spawn_owned(ball, BodyRole::Dynamic)
        .expect("spawn");
    let timeout = Duration::from_secs(10);
    for _ in 0..ROUNDS {
        lockstep_round(&mut clusters, timeout, |index, context, physics| {
            if index == 0 && context.tick() == PUSH_AT {
                physics.apply_impulse(ball.id, IMPULSE).expect("routed");
            }
        })
        .expect("round");
    }
    let stats = clusters[1].stats();
    let at = clusters[1].sim().state(ball.id).expect("B has it").position;
    (at, stats.ops_applied)
}

fn apart(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f32>().sqrt()
}

/// A ball in free flight, pushed by a neighbour through its owner: where one world has it
/// (without the catch-up it ends a tick's motion behind: 1.5 cm here).
#[test]
fn a_routed_push_on_a_ball_in_flight_lands_as_in_one_world() {
    let (a, b) = (ClusterId::random(), ClusterId::random());
    let ball = ball_at(0.5, b).velocity([-1.0, 0.0, 0.0]);
    let truth = one_world(&ball);
    let (at, applied) = split(&ball, a, b);
    assert_eq!(applied, 1, "the push reached its owner");
    let missed = apart(truth, ball.position);
    assert!(missed > 0.1, "the push moved the ball ({missed} m)");
    assert!(
        apart(at, truth) < 1e-4,
        "split {at:?}, one world {truth:?}: {} m apart",
        apart(at, truth)
    );
}
