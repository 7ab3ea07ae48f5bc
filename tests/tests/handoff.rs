//! A hand-off survives a lost frame: the old owner repeats it in every replication frame until
//! the new owner's frames mention the entity, and a repeat that arrives after the entity moved
//! on is recognised by its epoch and changes nothing.
//!
//! Two free-running clusters in one process on shared memory with a receive buffer of 4: the
//! new owner stalls (does not tick) while the old owner runs on, so the frame that carried the
//! hand-off is overwritten before it is read — as for a pod stopped past its buffer.

use seam_proxy::{
    AuthorityMode, AuthorityPolicy, AuthorityView, Cluster, ClusterConfig, Region, WorldCluster,
    lockstep_round,
};
use seam_sim::BodyRole;
use seam_sim::wire::{ClusterId, EntityId};
use seam_tests::{TestContext, ball_at};

seam_tests::backend_tests!(
    [shm: Shm],
    [
        a_handoff_whose_frame_is_lost_still_lands,
        a_handoff_from_a_neighbour_a_tick_ahead_is_taken_at_its_own_tick,
        a_platform_keeps_its_role_and_velocity_through_a_handoff
    ]
);

/// Two neighbouring clusters on `url`, zero gravity, scripted authority, each tuned by `tune`
/// (its index, both ids, its configuration); returns them and their ids.
fn pair(
    url: &str,
    tune: impl Fn(usize, &[ClusterId; 2], &mut ClusterConfig),
) -> (Vec<Cluster>, ClusterId, ClusterId) {
    let ids = [ClusterId::random(), ClusterId::random()];
    let clusters = (0..2)
        .map(|index| {
            let mut config = ClusterConfig::new(ids[index], vec![ids[1 - index]], url);
            config.gravity = [0.0; 3];
            config.authority = AuthorityMode::Scripted;
            tune(index, &ids, &mut config);
            Cluster::new(config).expect("cluster")
        })
        .collect();
    (clusters, ids[0], ids[1])
}

/// Free-running clusters that do not tick together: A always ticks just before B, so each
/// frame B reads is of a tick B has not stepped yet. A hand-off in such a frame carries the
/// body's state after A's step; B takes it at B's next tick, so the body is stepped once per
/// tick across the hand-off and ends where one world would have it (before: B took it at
/// once and stepped it again, one tick ahead — 0.1 m here, 6.7 m for a 400 m/s shot at 60 Hz).
fn a_handoff_from_a_neighbour_a_tick_ahead_is_taken_at_its_own_tick(ctx: &TestContext) {
    let (mut clusters, a, b) = pair(&ctx.url(), |_, _, _| {});
    let speed = 6.0;
    let ball = ball_at(-1.0, a).velocity([speed, 0.0, 0.0]);
    clusters[0]
        .spawn_owned(&ball, BodyRole::Dynamic)
        .expect("spawn");
    let rounds = 30u32;
    for round in 0..rounds {
        if round == 10 {
            clusters[0]
                .transfer_authority(ball.id, b)
                .expect("hand over");
        }
        for cluster in &mut clusters {
            cluster.tick(|_, _| {}).expect("tick");
        }
    }
    let b_world = clusters[1].sim();
    let info = b_world.info(ball.id).expect("B has the ball");
    assert_eq!(info.owner, b, "B owns the ball");
    assert_eq!(b_world.tick(), u64::from(rounds));
    // Zero gravity, nothing to meet: one world moves it speed · dt a step, for every step.
    let dt = clusters[1].config().dt;
    let expected = -1.0 + speed * dt * rounds as f32;
    let x = b_world.state(ball.id).expect("state").position[0];
    assert!(
        (x - expected).abs() < 1e-3,
        "after {rounds} ticks the ball is at x = {x}, one world has it at {expected} \
         ({:.2} ticks ahead)",
        (x - expected) / (speed * dt)
    );
}

fn a_handoff_whose_frame_is_lost_still_lands(ctx: &TestContext) {
    let url = ctx.url_with("buffer=4");
    let (mut clusters, a, b) = pair(&url, |_, _, _| {});
    let ball = ball_at(0.0, a);
    clusters[0]
        .spawn_owned(&ball, BodyRole::Dynamic)
        .expect("spawn");
    for _ in 0..3 {
        for cluster in &mut clusters {
            cluster.tick(|_, _| {}).expect("tick");
        }
    }
    assert!(clusters[1].sim().contains(ball.id), "B has a proxy");

    // A hands the ball to B, then runs on for 10 frames while B stalls: B's buffer of 4 keeps
    // only the newest frames, so the one that carried the hand-off is gone.
    clusters[0]
        .transfer_authority(ball.id, b)
        .expect("hand over");
    for _ in 0..11 {
        clusters[0].tick(|_, _| {}).expect("A ticks");
    }
    // B wakes, A hears it and ticks on: the ball ends with exactly one owner, B.
    for _ in 0..5 {
        for cluster in &mut clusters {
            cluster.tick(|_, _| {}).expect("tick");
        }
    }
    assert!(
        clusters[1].transport_stats().overflow_drops > 0,
        "B lost frames: {:?}",
        clusters[1].transport_stats()
    );
    let owners: Vec<ClusterId> = clusters
        .iter()
        .filter(|c| {
            c.sim()
                .info(ball.id)
                .is_some_and(|i| i.owner == c.id() && i.role == BodyRole::Dynamic)
        })
        .map(|c| c.id())
        .collect();
    assert_eq!(owners, vec![b], "owned once, by B");
    assert_eq!(clusters[1].stats().handoffs_in, 1);
    assert_eq!(
        clusters[0].sim().info(ball.id).map(|i| i.owner),
        Some(b),
        "A keeps a proxy of B's ball"
    );

    // B hands it back; A's last repeats of the old hand-off to B, still in flight, are older
    // than B's own hand-off and change nothing at B.
    clusters[1]
        .transfer_authority(ball.id, a)
        .expect("hand back");
    for _ in 0..5 {
        for cluster in &mut clusters {
            cluster.tick(|_, _| {}).expect("tick");
        }
    }
    let owned_by = |c: &Cluster| {
        c.sim()
            .info(ball.id)
            .is_some_and(|i| i.owner == c.id() && i.role == BodyRole::Dynamic)
    };
    assert!(
        owned_by(&clusters[0]) && !owned_by(&clusters[1]),
        "back with A, once"
    );
}

/// An authority policy that hands every entity its cluster owns to one neighbour at once.
struct HandEverythingTo(ClusterId);

impl AuthorityPolicy for HandEverythingTo {
    fn decide(&mut self, view: &AuthorityView<'_>, handoffs: &mut Vec<(EntityId, ClusterId)>) {
        handoffs.extend(view.owned.iter().map(|(state, _)| (state.id, self.0)));
    }
}

/// B hands back at once every entity it takes. In lock-step, A's next frame still repeats its
/// hand-off to B (A has not read B's answer yet) and reaches B after B gave the entity back:
/// by its epoch B knows it for an old one and does not take the entity again. At every step
/// exactly one cluster simulates it.
#[test]
fn a_repeated_handoff_arriving_after_the_entity_moved_on_changes_nothing() {
    let url = format!("local?prefix=seam_repeat_{}_", std::process::id());
    let (mut clusters, a, b) = pair(&url, |_, _, _| {});
    clusters[1].set_authority_policy(Box::new(HandEverythingTo(a)));
    let ball = ball_at(0.0, a);
    clusters[0]
        .spawn_owned(&ball, BodyRole::Dynamic)
        .expect("spawn");
    let timeout = std::time::Duration::from_secs(10);
    for _ in 0..2 {
        lockstep_round(&mut clusters, timeout, |_, _, _| {}).expect("round");
    }
    clusters[0]
        .transfer_authority(ball.id, b)
        .expect("hand over");
    for round in 0..10 {
        let mut simulated = 0;
        lockstep_round(&mut clusters, timeout, |_, context, _| {
            if context
                .entity(ball.id)
                .is_some_and(|info| info.role == BodyRole::Dynamic)
            {
                simulated += 1;
            }
        })
        .expect("round");
        assert!(simulated <= 1, "round {round}: simulated twice");
    }
    let owners = clusters
        .iter()
        .filter(|c| c.sim().info(ball.id).is_some_and(|i| i.owner == c.id()))
        .count();
    assert_eq!(owners, 1, "one owner at the end");
    assert_eq!(clusters[1].stats().handoffs_in, 1, "B took it once");
    assert_eq!(clusters[0].stats().handoffs_in, 1, "and gave it back once");
}

/// A hands the ball to B, which hands it straight back (its policy says so), and A dies before
/// reading that: A's last frame lists the ball, but as handed to B. When B takes A for dead it
/// must take the ball back, not count it as A's and drop it. (Before the fix this lost the
/// `crossfire` runner under `seam chaos`.)
#[test]
fn a_hand_back_the_dead_never_took_is_taken_back() {
    let url = format!("local?prefix=seam_handback_{}_", std::process::id());
    let region = |x0: f32, x1: f32| Region {
        min: [x0, -100.0, -100.0],
        max: [x1, 100.0, 100.0],
    };
    let regions = [region(-50.0, 0.0), region(0.0, 50.0)];
    let (mut clusters, a, _) = pair(&url, |index, ids, config| {
        config.region = regions[index];
        config.spread = 2.0;
        config.neighbour_timeout_ticks = 10;
        config.world = (0..2)
            .map(|i| WorldCluster {
                spread: 2.0,
                id: ids[i],
                region: regions[i],
                neighbours: vec![ids[1 - i]],
            })
            .collect();
    });
    let b = clusters[1].id();
    clusters[1].set_authority_policy(Box::new(HandEverythingTo(a)));
    // Within B's spread, so B models it and may be handed it.
    let ball = ball_at(-1.0, a);
    clusters[0]
        .spawn_owned(&ball, BodyRole::Dynamic)
        .expect("spawn");
    let dt = std::time::Duration::from_secs_f32(clusters[0].config().dt);
    for _ in 0..3 {
        for cluster in &mut clusters {
            cluster.tick(|_, _| {}).expect("tick");
        }
        std::thread::sleep(dt);
    }
    clusters[0]
        .transfer_authority(ball.id, b)
        .expect("hand over");
    clusters[0].tick(|_, _| {}).expect("A's last tick");
    // A is dead from here on. B takes the ball, hands it back at once, and waits.
    for _ in 0..30 {
        clusters[1].tick(|_, _| {}).expect("B ticks");
        std::thread::sleep(dt);
    }
    let stats = clusters[1].stats();
    assert_eq!(stats.neighbours_lost, 1, "B took A for dead: {stats:?}");
    let info = clusters[1].sim().info(ball.id).expect("B has the ball");
    assert_eq!(
        (info.owner, info.role),
        (b, BodyRole::Dynamic),
        "B took back the hand-back A never took: {stats:?}"
    );
    assert_eq!(stats.handoffs_reclaimed, 1, "{stats:?}");
}

/// A pod about to stop stops its policy's hand-offs, so none is in flight when its neighbours
/// stop (a hand-off published in the last tick reaches no one, and under `seam chaos` its
/// entity ended owned by nobody). A's policy hands everything to B; after
/// `stop_policy_handoffs` it hands nothing more, while B's policy, not stopped, still does.
#[test]
fn stopped_policy_handoffs_hand_nothing_more() {
    let url = format!("local?prefix=seam_drain_{}_", std::process::id());
    let (mut clusters, a, b) = pair(&url, |_, _, _| {});
    clusters[0].set_authority_policy(Box::new(HandEverythingTo(b)));
    clusters[1].set_authority_policy(Box::new(HandEverythingTo(a)));
    clusters[0].stop_policy_handoffs();
    let (kept, handed) = (ball_at(-2.0, a), ball_at(2.0, b));
    clusters[0]
        .spawn_owned(&kept, BodyRole::Dynamic)
        .expect("spawn");
    clusters[1]
        .spawn_owned(&handed, BodyRole::Dynamic)
        .expect("spawn");
    let timeout = std::time::Duration::from_secs(10);
    for _ in 0..5 {
        lockstep_round(&mut clusters, timeout, |_, _, _| {}).expect("round");
    }
    assert_eq!(clusters[0].stats().handoffs_out, 0, "A's policy is stopped");
    assert_eq!(clusters[1].stats().handoffs_out, 1, "B's still hands");
    let owner = |id: EntityId| {
        clusters
            .iter()
            .filter(|c| c.sim().info(id).is_some_and(|i| i.owner == c.id()))
            .map(|c| c.id())
            .collect::<Vec<_>>()
    };
    assert_eq!(owner(kept.id), vec![a]);
    assert_eq!(
        owner(handed.id),
        vec![a],
        "B's ball handed to A, taken once"
    );
}

/// A body its owner moves kinematically (a platform) is proxied with its velocity even in the
/// Fixed proxy mode (Rapier carries what rests on a body only through that body's velocity),
/// and handed over it stays kinematic with its velocity: the new owner moves it on at the same
/// speed, one step a tick, and the old owner follows it as a moving proxy. (Before, the proxy
/// was a Fixed body with no velocity, and the new owner took the platform as a Fixed body,
/// stopped for good.)
fn a_platform_keeps_its_role_and_velocity_through_a_handoff(ctx: &TestContext) {
    let (mut clusters, a, b) = pair(&ctx.url(), |_, _, config| {
        assert_eq!(config.proxy_mode, seam_proxy::ProxyMode::Fixed);
    });
    let speed = 2.0;
    let platform = ball_at(-1.0, a).velocity([speed, 0.0, 0.0]);
    clusters[0]
        .spawn_owned(&platform, BodyRole::KinematicVelocityBased)
        .expect("spawn");
    let rounds = 40u32;
    for round in 0..rounds {
        if round == 20 {
            let proxy = clusters[1].sim().state(platform.id).expect("B proxies it");
            let role = clusters[1].sim().info(platform.id).map(|i| i.role);
            assert_eq!(
                role,
                Some(BodyRole::KinematicVelocityBased),
                "a moving proxy"
            );
            assert!((proxy.linvel[0] - speed).abs() < 1e-3, "{proxy:?}");
            clusters[0]
                .transfer_authority(platform.id, b)
                .expect("hand over");
        }
        for cluster in &mut clusters {
            cluster.tick(|_, _| {}).expect("tick");
        }
    }
    let b_world = clusters[1].sim();
    let info = b_world.info(platform.id).expect("B has the platform");
    assert_eq!(
        (info.owner, info.role),
        (b, BodyRole::KinematicVelocityBased),
        "B owns it, kinematic"
    );
    let state = b_world.state(platform.id).expect("state");
    let dt = clusters[1].config().dt;
    let expected = -1.0 + speed * dt * rounds as f32;
    assert!(
        (state.linvel[0] - speed).abs() < 1e-4 && (state.position[0] - expected).abs() < 1e-3,
        "B moves it on at {speed} m/s to x = {expected}: {state:?}"
    );
    let a_role = clusters[0].sim().info(platform.id).map(|i| i.role);
    assert_eq!(
        a_role,
        Some(BodyRole::KinematicVelocityBased),
        "A follows it moving"
    );
}
