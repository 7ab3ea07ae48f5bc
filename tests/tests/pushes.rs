//! A push routed to another owner acts on the tick it was issued, as in one world.
//!
//! With the exchange (`ClusterConfig::exchange`, the default) the issuer sends its ops before
//! its step and the owner applies them before its own step of the same tick, so a body pushed
//! through its owner — in flight or resting on a floor — moves as in one world; the impulses
//! game code gives the issuer's own bodies travel with them and push the owner's proxies of
//! those bodies in the same step (two crates side by side, each pushed by one blast). Without
//! it the push reaches the owner a tick later (lock-step), which adds back the motion a body
//! in free flight missed in that tick; a body touching something is pushed late without the
//! catch-up, since what it would have met in the missed tick with its new velocity cannot be
//! replayed.

use std::time::Duration;

use seam_proxy::{AuthorityMode, Cluster, ClusterConfig, ClusterError, lockstep_round};
use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, Shape};
use seam_sim::{BodyRole, ClusterSim, LocalOnly, SimConfig};
use seam_tests::ball_at;

const PUSH_AT: u64 = 5;
const ROUNDS: u64 = 30;

/// A world of bodies, each owned by cluster 0 or 1, on an optional floor of scenery, and the
/// pushes cluster 0's game code gives at `PUSH_AT`.
struct Scene {
    bodies: Vec<(EntityState, usize)>,
    floor: Option<EntityState>,
    gravity: [f32; 3],
    pushes: Vec<(EntityId, [f32; 3])>,
}

/// Where one world has every body after `ROUNDS` steps, the pushes given at `PUSH_AT`.
fn one_world(scene: &Scene) -> Vec<[f32; 3]> {
    let me = ClusterId::random();
    let mut config = SimConfig::new(me);
    config.gravity = scene.gravity;
    let mut sim = ClusterSim::new(config);
    if let Some(floor) = &scene.floor {
        sim.spawn(floor, BodyRole::Fixed).expect("floor");
    }
    for (body, _) in &scene.bodies {
        let owned = EntityState {
            cluster_id: me,
            ..*body
        };
        sim.spawn(&owned, BodyRole::Dynamic).expect("spawn");
    }
    for tick in 0..ROUNDS {
        sim.run_user(&mut LocalOnly, |context, physics| {
            if context.tick() == PUSH_AT {
                for &(id, impulse) in &scene.pushes {
                    physics.apply_impulse(id, impulse)?;
                }
            }
            Ok::<(), seam_sim::SimError>(())
        })
        .expect("user");
        sim.step();
        assert_eq!(sim.tick(), tick + 1);
    }
    positions(&sim, scene)
}

fn positions(sim: &ClusterSim, scene: &Scene) -> Vec<[f32; 3]> {
    scene
        .bodies
        .iter()
        .map(|(body, _)| sim.state(body.id).expect("a body").position)
        .collect()
}

/// The same split over two clusters in lock-step (cluster 0 pushes): where each body's owner
/// has it after `ROUNDS` rounds, and how many ops the owners applied.
fn split(scene: &Scene, ids: [ClusterId; 2], exchange: bool) -> (Vec<[f32; 3]>, u64) {
    let url = format!(
        "local?prefix=seam_pushes_{}_{}_",
        std::process::id(),
        ids[1]
    );
    let mut clusters: Vec<Cluster> = [(ids[0], ids[1]), (ids[1], ids[0])]
        .into_iter()
        .map(|(me, other)| {
            let mut config = ClusterConfig::new(me, vec![other], &url);
            config.gravity = scene.gravity;
            config.authority = AuthorityMode::Scripted;
            config.exchange = exchange;
            Cluster::new(config).expect("cluster")
        })
        .collect();
    for cluster in &mut clusters {
        if let Some(floor) = &scene.floor {
            cluster.spawn_scenery(floor).expect("floor");
        }
    }
    for (body, owner) in &scene.bodies {
        clusters[*owner]
            .spawn_owned(body, BodyRole::Dynamic)
            .expect("spawn");
    }
    let timeout = Duration::from_secs(10);
    for _ in 0..ROUNDS {
        lockstep_round(&mut clusters, timeout, |index, context, physics| {
            if index == 0 && context.tick() == PUSH_AT {
                for &(id, impulse) in &scene.pushes {
                    physics
                        .apply_impulse(id, impulse)
                        .expect("applied or routed");
                }
            }
        })
        .expect("round");
    }
    let at = scene
        .bodies
        .iter()
        .map(|(body, owner)| {
            clusters[*owner]
                .sim()
                .state(body.id)
                .expect("its owner has it")
                .position
        })
        .collect();
    (at, clusters[1].stats().ops_applied)
}

fn apart(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f32>().sqrt()
}

/// The largest distance between the split's bodies and one world's.
fn worst(split: &[[f32; 3]], truth: &[[f32; 3]]) -> f32 {
    split
        .iter()
        .zip(truth)
        .map(|(&s, &t)| apart(s, t))
        .fold(0.0, f32::max)
}

/// A ball in free flight owned by cluster 1, pushed by cluster 0.
fn ball_in_flight(owner: ClusterId) -> Scene {
    let ball = ball_at(0.5, owner).velocity([-1.0, 0.0, 0.0]);
    Scene {
        pushes: vec![(ball.id, [40.0, 0.0, 25.0])],
        bodies: vec![(ball, 1)],
        floor: None,
        gravity: [0.0; 3],
    }
}

fn crate_at(x: f32, owner: ClusterId) -> EntityState {
    let body = BodySpec::new(Shape::cuboid(0.5, 0.5, 0.5)).density(100.0);
    EntityState::new(EntityId::random(), owner, body).at([x, 0.5, 0.0])
}

/// Crates resting on a floor under gravity, owned by cluster 1, or `touching` one of each
/// cluster's side by side; cluster 0 pushes every crate along x, as a blast would.
fn crates_on_a_floor(ids: [ClusterId; 2], touching: bool) -> Scene {
    let floor_body = BodySpec::new(Shape::cuboid(20.0, 0.5, 20.0)).density(1.0);
    let floor =
        EntityState::new(EntityId::random(), ClusterId::SCENERY, floor_body).at([0.0, -0.5, 0.0]);
    let bodies = if touching {
        vec![(crate_at(-0.5, ids[0]), 0), (crate_at(0.5, ids[1]), 1)]
    } else {
        vec![(crate_at(0.5, ids[1]), 1)]
    };
    Scene {
        pushes: bodies
            .iter()
            .map(|(body, _)| (body.id, [300.0, 0.0, 40.0]))
            .collect(),
        bodies,
        floor: Some(floor),
        gravity: [0.0, -9.81, 0.0],
    }
}

/// A ball in free flight, pushed through its owner: where one world has it, with the exchange
/// and without it (then caught up: without the catch-up it ends a tick's motion behind, 1.5
/// cm here).
#[test]
fn a_routed_push_on_a_ball_in_flight_lands_as_in_one_world() {
    let ids = [ClusterId::random(), ClusterId::random()];
    let scene = ball_in_flight(ids[1]);
    let truth = one_world(&scene);
    assert!(
        apart(truth[0], scene.bodies[0].0.position) > 0.1,
        "the push moved the ball"
    );
    for exchange in [true, false] {
        let (at, applied) = split(&scene, ids, exchange);
        assert_eq!(
            applied, 1,
            "the push reached its owner (exchange {exchange})"
        );
        let off = worst(&at, &truth);
        assert!(off < 1e-4, "exchange {exchange}: {off} m from one world");
    }
}

/// A crate resting on a floor, pushed through its owner: with the exchange it moves as in one
/// world; a tick late (no exchange) it cannot be caught up, and ends centimetres off.
#[test]
fn a_routed_push_on_a_resting_crate_acts_on_its_tick() {
    let ids = [ClusterId::random(), ClusterId::random()];
    let scene = crates_on_a_floor(ids, false);
    let truth = one_world(&scene);
    assert!(apart(truth[0], scene.bodies[0].0.position) > 0.1);
    let (exchanged, applied) = split(&scene, ids, true);
    assert_eq!(applied, 1);
    let off = worst(&exchanged, &truth);
    assert!(off < 1e-4, "exchanged: {off} m from one world");
    let (late, _) = split(&scene, ids, false);
    let off = worst(&late, &truth);
    assert!(off > 0.01, "a tick late: {off} m from one world");
}

/// A blast on two touching crates of different owners: the issuer pushes its own and routes
/// the other's; the owner's world pushes its proxy of the issuer's crate in the same step, so
/// both worlds push both crates apart together, as one world does.
#[test]
fn a_blast_on_touching_crates_of_two_owners_acts_as_in_one_world() {
    let ids = [ClusterId::random(), ClusterId::random()];
    let scene = crates_on_a_floor(ids, true);
    let truth = one_world(&scene);
    let (exchanged, applied) = split(&scene, ids, true);
    assert_eq!(applied, 1, "one push routed, one applied by its issuer");
    let off = worst(&exchanged, &truth);
    assert!(off < 1e-3, "exchanged: {off} m from one world");
    let (late, _) = split(&scene, ids, false);
    let off = worst(&late, &truth);
    assert!(off > 0.01, "a tick late: {off} m from one world");
}

/// A lock-step tick's halves in the wrong order are an error, and the cluster goes on
/// ticking once they are called in order.
#[test]
fn lockstep_halves_out_of_order_are_refused() {
    let me = ClusterId::random();
    let url = format!("local?prefix=seam_pushes_order_{}_", std::process::id());
    let mut cluster = Cluster::new(ClusterConfig::new(me, Vec::new(), &url)).expect("cluster");
    let timeout = Duration::from_secs(1);
    assert!(matches!(
        cluster.finish_lockstep(timeout),
        Err(ClusterError::TickOrder(_))
    ));
    cluster.begin_lockstep(timeout, |_, _| {}).expect("begin");
    assert!(matches!(
        cluster.begin_lockstep(timeout, |_, _| {}),
        Err(ClusterError::TickOrder(_))
    ));
    cluster.finish_lockstep(timeout).expect("finish");
    cluster
        .tick_lockstep(timeout, |_, _| {})
        .expect("a whole tick");
    assert_eq!(cluster.sim().tick(), 2);
}
