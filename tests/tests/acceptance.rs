//! The three layers end to end, each test run on shm, local and redis (one macro for every
//! per-backend test, `seam_tests::backend_tests!`): `shm::raycast_hits_proxy`,
//! `local::raycast_hits_proxy`, `redis::raycast_hits_proxy`, …
//! Clusters run in lock-step in this process, so every run is deterministic on every transport.

use std::time::Duration;

use seam_proxy::{
    AuthorityPolicy, AuthorityView, Cluster, ClusterConfig, CustomProxy, ProxyMode, Region,
    lockstep_round,
};
use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, Shape};
use seam_sim::{BodyRole, JointSpec, WriteOutcome};
use seam_tests::TestContext;
use seam_transport::Backend;

const TIMEOUT: Duration = Duration::from_secs(10);

seam_tests::backend_tests!(
    [shm: Shm, local: Local, redis: Redis],
    [
        raycast_hits_proxy,
        impulse_routed_to_authority,
        contact_flows_back,
        authority_transfer_atomic,
        joint_refused_across_clusters,
        velocity_proxy_smoother_than_fixed,
        flip_only_from_the_owner,
        op_after_hand_off_is_forwarded_once,
        forwarded_op_is_never_forwarded_again,
        forwarded_op_applied_by_its_forwarder_when_the_entity_comes_back,
        scenery_is_loaded_everywhere_and_never_replicated,
        only_the_region_is_modelled,
        custom_proxy_hook_moves_proxies,
        third_cluster_routes_to_the_new_owner,
        routed_ops_carry_their_stage_times,
    ]
);

/// Two neighbouring clusters on the test's transport, zero gravity unless `gravity`.
fn pair(ctx: &TestContext, gravity: bool, tune: impl Fn(&mut ClusterConfig)) -> Vec<Cluster> {
    let (a, b) = (ClusterId::random(), ClusterId::random());
    [(a, b), (b, a)]
        .into_iter()
        .map(|(me, other)| {
            let mut config = ClusterConfig::new(me, vec![other], &ctx.url());
            if !gravity {
                config.gravity = [0.0; 3];
            }
            tune(&mut config);
            Cluster::new(config).expect("cluster")
        })
        .collect()
}

/// Three clusters, each the neighbour of both others, zero gravity, configured by `tune`; the
/// first owns a ball at the origin, which the others know as a proxy after two rounds.
fn trio_with_a_ball(
    ctx: &TestContext,
    tune: impl Fn(&mut ClusterConfig),
) -> (Vec<Cluster>, Vec<ClusterId>, EntityState) {
    let ids: Vec<ClusterId> = (0..3).map(|_| ClusterId::random()).collect();
    let mut clusters: Vec<Cluster> = ids
        .iter()
        .map(|&me| {
            let others = ids.iter().copied().filter(|&c| c != me).collect();
            let mut config = ClusterConfig::new(me, others, &ctx.url());
            config.gravity = [0.0; 3];
            tune(&mut config);
            Cluster::new(config).expect("cluster")
        })
        .collect();
    let entity = ball([0.0; 3], [0.0; 3]);
    clusters[0]
        .spawn_owned(&entity, BodyRole::Dynamic)
        .expect("spawn");
    rounds(&mut clusters, 2);
    (clusters, ids, entity)
}

fn ball(position: [f32; 3], linvel: [f32; 3]) -> EntityState {
    // The owner is replaced by spawn_owned.
    EntityState::new(
        EntityId::random(),
        ClusterId::random(),
        BodySpec::new(Shape::ball(0.5)),
    )
    .at(position)
    .velocity(linvel)
}

fn rounds(clusters: &mut [Cluster], n: usize) {
    for _ in 0..n {
        lockstep_round(clusters, TIMEOUT, |_, _, _| {}).expect("round");
    }
}

fn raycast_hits_proxy(ctx: &TestContext) {
    let mut clusters = pair(ctx, false, |_| {});
    let target = ball([10.0, 0.0, 0.0], [0.0; 3]);
    clusters[0]
        .spawn_owned(&target, BodyRole::Dynamic)
        .expect("spawn");
    rounds(&mut clusters, 1);
    let mut hit = None;
    lockstep_round(&mut clusters, TIMEOUT, |index, _, physics| {
        if index == 1 {
            hit = physics.raycast([0.0; 3], [1.0, 0.0, 0.0], 100.0, None);
        }
    })
    .expect("round");
    let hit = hit.expect("B's raycast hits its proxy of A's entity");
    assert_eq!(hit.entity, target.id);
    assert!(
        (hit.toi - 9.5).abs() < 1e-3,
        "at the proxy's surface: {}",
        hit.toi
    );
    assert_eq!(
        clusters[1].sim().info(target.id).expect("proxy").role,
        BodyRole::Fixed
    );
}

fn impulse_routed_to_authority(ctx: &TestContext) {
    let mut clusters = pair(ctx, false, |_| {});
    let target = ball([0.0; 3], [0.0; 3]);
    clusters[0]
        .spawn_owned(&target, BodyRole::Dynamic)
        .expect("spawn");
    let mass = 1000.0 * 4.0 / 3.0 * std::f32::consts::PI * 0.125;
    rounds(&mut clusters, 1);
    let mut outcome = None;
    lockstep_round(&mut clusters, TIMEOUT, |index, _, physics| {
        if index == 1 {
            outcome = Some(physics.apply_impulse(target.id, [mass * 2.0, 0.0, 0.0]));
        }
    })
    .expect("round");
    assert_eq!(outcome, Some(Ok(WriteOutcome::Routed)));
    let v = clusters[0].sim().state(target.id).expect("body").linvel[0];
    assert!(
        (v - 2.0).abs() < 1e-3,
        "A applied it before its step of the same tick (the exchange): Δv = J/m = 2, got {v}"
    );
    rounds(&mut clusters, 5);
    let v = clusters[0].sim().state(target.id).expect("body").linvel[0];
    assert!((v - 2.0).abs() < 1e-3, "applied exactly once: {v}");
    assert_eq!(clusters[1].stats().ops_routed, 1);
    assert_eq!(clusters[0].stats().ops_applied, 1);
    // B's Fixed proxy follows the pose A replicates (a Fixed body itself has no velocity).
    let (body, proxy) = (
        clusters[0].sim().state(target.id).expect("body").position[0],
        clusters[1].sim().state(target.id).expect("proxy").position[0],
    );
    assert!(
        proxy > 0.0 && (body - proxy).abs() < 2.0 * 2.0 / 60.0 + 1e-4,
        "{body} vs {proxy}"
    );
}

fn contact_flows_back(ctx: &TestContext) {
    let mut clusters = pair(ctx, true, |_| {});
    let mut ground = ball([0.0, -0.5, 0.0], [0.0; 3]);
    ground.body.shape = Shape::Cuboid {
        half_extents: [5.0, 0.5, 5.0],
    };
    clusters[1]
        .spawn_owned(&ground, BodyRole::Fixed)
        .expect("B's ground");
    let falling = ball([0.0, 1.5, 0.0], [0.0; 3]);
    clusters[0]
        .spawn_owned(&falling, BodyRole::Dynamic)
        .expect("A's ball");
    let mut seen_by_b = false;
    for _ in 0..120 {
        lockstep_round(&mut clusters, TIMEOUT, |index, context, _| {
            if index == 1 {
                seen_by_b |= context.contacts().iter().any(|c| {
                    c.started
                        && ((c.a, c.b) == (falling.id, ground.id)
                            || (c.a, c.b) == (ground.id, falling.id))
                });
            }
        })
        .expect("round");
    }
    assert!(
        seen_by_b,
        "B sees the contact of A's ball with A's proxy of B's ground"
    );
    assert!(clusters[0].stats().contacts_sent >= 1);
    assert!(clusters[1].stats().contacts_received >= 1);
}

fn authority_transfer_atomic(ctx: &TestContext) {
    let mut clusters = pair(ctx, false, |_| {});
    let (a, b) = (clusters[0].id(), clusters[1].id());
    let moving = ball([0.0; 3], [3.0, 0.0, 0.0]);
    clusters[0]
        .spawn_owned(&moving, BodyRole::Dynamic)
        .expect("spawn");
    rounds(&mut clusters, 2);
    let mut positions = Vec::new();
    for round in 0..20 {
        if round == 5 {
            clusters[0]
                .transfer_authority(moving.id, b)
                .expect("hand over");
        }
        let mut dynamic = Vec::new();
        lockstep_round(&mut clusters, TIMEOUT, |index, context, physics| {
            let info = context.entity(moving.id).expect("both model it");
            if info.role == BodyRole::Dynamic {
                dynamic.push(index);
                positions.push(physics.translation(moving.id).expect("there")[0]);
            }
        })
        .expect("round");
        assert_eq!(
            dynamic.len(),
            1,
            "round {round}: exactly one dynamic body, got {dynamic:?}"
        );
    }
    let (at_a, at_b) = (
        clusters[0].sim().info(moving.id).expect("A models it"),
        clusters[1].sim().info(moving.id).expect("B models it"),
    );
    assert_eq!(
        (at_a.owner, at_a.role),
        (b, BodyRole::Fixed),
        "A's body became a proxy"
    );
    assert_eq!(
        (at_b.owner, at_b.role),
        (b, BodyRole::Dynamic),
        "B's proxy became the body"
    );
    let _ = a;
    // Continuous: the body advances v·dt every tick across the hand-off.
    let step = 3.0 / 60.0;
    for pair in positions.windows(2) {
        assert!(
            (pair[1] - pair[0] - step).abs() < 1e-4,
            "jump at the hand-off: {positions:?}"
        );
    }
    assert_eq!(clusters[0].stats().handoffs_out, 1);
    assert_eq!(clusters[1].stats().handoffs_in, 1);
}

fn joint_refused_across_clusters(ctx: &TestContext) {
    let mut clusters = pair(ctx, false, |_| {});
    let (theirs, ours) = (ball([0.0; 3], [0.0; 3]), ball([2.0, 0.0, 0.0], [0.0; 3]));
    let other = ball([4.0, 0.0, 0.0], [0.0; 3]);
    clusters[0]
        .spawn_owned(&theirs, BodyRole::Dynamic)
        .expect("spawn");
    clusters[1]
        .spawn_owned(&ours, BodyRole::Dynamic)
        .expect("spawn");
    clusters[1]
        .spawn_owned(&other, BodyRole::Dynamic)
        .expect("spawn");
    rounds(&mut clusters, 2);
    let spec = JointSpec::Fixed {
        anchor_a: [0.0; 3],
        anchor_b: [0.0; 3],
    };
    let (mut across, mut local) = (Some(None), None);
    lockstep_round(&mut clusters, TIMEOUT, |index, _, physics| {
        if index == 1 {
            across = Some(physics.create_joint(ours.id, theirs.id, spec));
            local = physics.create_joint(ours.id, other.id, spec);
        }
    })
    .expect("round");
    assert_eq!(across, Some(None), "a joint with A's entity is refused");
    assert!(local.is_some(), "a joint between B's own entities is made");
}

/// Mean distance between B's proxy and A's body over `ticks`, replication every 4 ticks.
fn tracking_error(ctx: &TestContext, mode: ProxyMode) -> f32 {
    let mut clusters = pair(ctx, false, |config| {
        config.proxy_mode = mode;
        config.replication_interval = 4;
    });
    let moving = ball([0.0; 3], [6.0, 0.0, 0.0]);
    clusters[0]
        .spawn_owned(&moving, BodyRole::Dynamic)
        .expect("spawn");
    rounds(&mut clusters, 12);
    let mut total = 0.0;
    const TICKS: usize = 80;
    for _ in 0..TICKS {
        rounds(&mut clusters, 1);
        let truth = clusters[0].sim().state(moving.id).expect("body").position[0];
        let proxy = clusters[1].sim().state(moving.id).expect("proxy").position[0];
        total += (truth - proxy).abs();
    }
    total / TICKS as f32
}

fn velocity_proxy_smoother_than_fixed(ctx: &TestContext) {
    let fixed = tracking_error(ctx, ProxyMode::Fixed);
    let velocity = tracking_error(ctx, ProxyMode::KinematicVelocityBased);
    assert!(
        velocity < 0.5 * fixed,
        "velocity-based proxy error {velocity} m should be well under the Fixed proxy's {fixed} m"
    );
}

/// Every state in every cluster, as raw bits, in entity order.
fn world_bits(clusters: &[Cluster]) -> Vec<Vec<(EntityId, [u32; 13])>> {
    clusters
        .iter()
        .map(|cluster| {
            let sim = cluster.sim();
            let mut states: Vec<(EntityId, [u32; 13])> = sim
                .entities()
                .filter_map(|(id, _)| sim.state(id))
                .map(|s| (s.id, s.motion_bits()))
                .collect();
            states.sort_by_key(|(id, _)| *id);
            states
        })
        .collect()
}

/// The same scripted scene, with fixed ids, on one transport: A's balls fall onto B's ground,
/// B pushes A's balls, A hands one ball to B.
fn scripted_scene(ctx: &TestContext) -> Vec<Vec<(EntityId, [u32; 13])>> {
    let (a, b) = (ClusterId::random(), ClusterId::random());
    let mut clusters: Vec<Cluster> = [(a, b), (b, a)]
        .into_iter()
        .map(|(me, other)| {
            Cluster::new(ClusterConfig::new(me, vec![other], &ctx.url())).expect("cluster")
        })
        .collect();
    let mut ground = ball([0.0, -0.5, 0.0], [0.0; 3]);
    ground.id = EntityId::from_u128(1);
    ground.body.shape = Shape::Cuboid {
        half_extents: [20.0, 0.5, 20.0],
    };
    clusters[1]
        .spawn_owned(&ground, BodyRole::Fixed)
        .expect("ground");
    let balls: Vec<EntityId> = (0..12u128)
        .map(|i| {
            let mut state = ball(
                [
                    (i % 4) as f32 * 1.2 - 2.0,
                    1.0 + (i / 4) as f32 * 1.1,
                    (i % 3) as f32 * 0.3,
                ],
                [0.5, 0.0, -0.2],
            );
            state.id = EntityId::from_u128(100 + i);
            clusters[0]
                .spawn_owned(&state, BodyRole::Dynamic)
                .expect("ball");
            state.id
        })
        .collect();
    for round in 0..90u64 {
        if round == 40 {
            clusters[0]
                .transfer_authority(balls[3], b)
                .expect("hand over");
        }
        lockstep_round(&mut clusters, TIMEOUT, |index, context, physics| {
            if index == 1 && context.tick() % 10 == 5 {
                let target = balls[(context.tick() / 10) as usize % balls.len()];
                let _ = physics.apply_impulse(target, [0.0, 300.0, 150.0]);
            }
        })
        .expect("round");
    }
    let (at_a, at_b) = (clusters[0].stats(), clusters[1].stats());
    assert!(
        at_a.ops_applied >= 8,
        "routed impulses were applied: {at_a:?}"
    );
    assert_eq!(at_b.handoffs_in, 1, "the hand-off happened");
    assert!(at_a.contacts_sent > 0, "balls landed on B's ground");
    world_bits(&clusters)
}

#[test]
fn transport_swap_identical() {
    let mut results = Vec::new();
    for backend in [Backend::Shm, Backend::Local, Backend::Redis] {
        match TestContext::new(backend) {
            Some(ctx) => results.push((backend, scripted_scene(&ctx))),
            None => eprintln!("transport_swap_identical: {backend} left out (see SKIP above)"),
        }
    }
    let (first, reference) = &results[0];
    assert_eq!(
        reference[0].len(),
        13,
        "A: 12 balls (one now a proxy) and the ground proxy"
    );
    for (backend, worlds) in &results[1..] {
        assert!(
            worlds == reference,
            "{backend} ended differently from {first}"
        );
    }
}

/// A replication frame on A's channel that names B's entity as A's, or claims to hand it to A,
/// is ignored: only an entity's current owner moves it.
fn flip_only_from_the_owner(ctx: &TestContext) {
    use seam_sim::wire::{ReplicationFrame, StateEncoding};
    let mut clusters = pair(ctx, false, |_| {});
    let (a, b) = (clusters[0].id(), clusters[1].id());
    let entity = ball([5.0, 0.0, 0.0], [0.0; 3]);
    clusters[1]
        .spawn_owned(&entity, BodyRole::Dynamic)
        .expect("B's entity");
    rounds(&mut clusters, 2);
    let before = clusters[1].sim().state(entity.id).expect("B's body");
    // A forger publishes on A's replication channel, as A, for the tick B will read next.
    let mut forger = ctx.open();
    let tick = clusters[1].sim().tick();
    let forged = ReplicationFrame {
        // What a forger copying A's frames would copy.
        incarnation: clusters[0].incarnation(),
        from: a,
        tick,
        states: vec![EntityState {
            cluster_id: a,
            position: [99.0, 0.0, 0.0],
            ..before
        }],
    };
    forger
        .publish(
            &seam_proxy::replication(a),
            &forged.encode(StateEncoding::Exact).expect("encodes"),
        )
        .expect("publish");
    rounds(&mut clusters, 2);
    let after = clusters[1].sim().info(entity.id).expect("still B's");
    assert_eq!(
        (after.owner, after.role),
        (b, BodyRole::Dynamic),
        "B still owns it"
    );
    let x = clusters[1].sim().state(entity.id).expect("body").position[0];
    assert!(
        (x - 5.0).abs() < 1e-4,
        "B's body did not move to the forged pose: {x}"
    );
    // The forged frame was refused either as a second frame of A's tick (the real one came
    // first and is kept) or, had it come first, by the owner rule.
    let stats = clusters[1].stats();
    assert!(
        stats.states_rejected + stats.frames_replayed >= 1,
        "{stats:?}"
    );
}

/// A write routed to the old owner after it handed the entity over is forwarded, once, to the
/// new owner, which applies it: Δv = J/m, exactly once. (With the exchange, a write of the
/// tick A hands the entity over reaches A before its step, and A applies it; so ops go after
/// the step here, as they do when an exchange frame misses its tick: B's write of that tick
/// reaches A after A gave the entity away.)
fn op_after_hand_off_is_forwarded_once(ctx: &TestContext) {
    let mut clusters = pair(ctx, false, |c| c.exchange = false);
    let b = clusters[1].id();
    let entity = ball([0.0; 3], [0.0; 3]);
    clusters[0]
        .spawn_owned(&entity, BodyRole::Dynamic)
        .expect("spawn");
    rounds(&mut clusters, 2);
    clusters[0]
        .transfer_authority(entity.id, b)
        .expect("hand over");
    let mass = 1000.0 * 4.0 / 3.0 * std::f32::consts::PI * 0.125;
    lockstep_round(&mut clusters, TIMEOUT, |index, _, physics| {
        if index == 1 {
            // B still sees A as the owner: the write is routed to A.
            assert_eq!(
                physics.apply_impulse(entity.id, [mass, 0.0, 0.0]),
                Ok(WriteOutcome::Routed)
            );
        }
    })
    .expect("round");
    rounds(&mut clusters, 3);
    let (a, b) = (clusters[0].stats(), clusters[1].stats());
    assert_eq!(a.ops_forwarded, 1, "A sent it on: {a:?}");
    assert_eq!((a.ops_applied, a.ops_not_here), (0, 0), "{a:?}");
    let acked = (a.ops_acked, clusters[1].stats().ops_acked);
    assert_eq!(
        acked,
        (1, 1),
        "B's op answered by A, which took it on; A's forward answered by B"
    );
    assert!(clusters.iter().all(|c| c.ops_unanswered() == 0));
    assert_eq!(b.ops_applied, 1, "B applied it: {b:?}");
    let v = clusters[1]
        .sim()
        .state(entity.id)
        .expect("B's body now")
        .linvel;
    assert!((v[0] - 1.0).abs() < 1e-4, "Δv = J/m, once: {v:?}");
}

/// An op is forwarded at most once: when it reaches a cluster that no longer owns the target
/// after being forwarded, that cluster answers "not here" and the forwarder, which took the op
/// on, sends it to where it now knows the entity to be: applied once, by the final owner.
fn forwarded_op_is_never_forwarded_again(ctx: &TestContext) {
    // Ops after the step, so that C's write of the hand-off's tick reaches A late (see
    // `op_after_hand_off_is_forwarded_once`).
    let (mut clusters, ids, entity) = trio_with_a_ball(ctx, |c| c.exchange = false);
    let mass = 1000.0 * 4.0 / 3.0 * std::f32::consts::PI * 0.125;
    // A hands it to B; in the same round C, still seeing A as the owner, writes to it. B's
    // policy hands everything it owns to C at once, so the write A forwards to B finds it gone.
    clusters[1].set_authority_policy(Box::new(HandEverythingTo(ids[2])));
    clusters[0]
        .transfer_authority(entity.id, ids[1])
        .expect("hand over");
    lockstep_round(&mut clusters, TIMEOUT, |index, _, physics| {
        if index == 2 {
            assert_eq!(
                physics.apply_impulse(entity.id, [mass, 0.0, 0.0]),
                Ok(WriteOutcome::Routed)
            );
        }
    })
    .expect("round");
    rounds(&mut clusters, 8);
    assert_eq!(
        clusters[2].sim().info(entity.id).map(|i| i.owner),
        Some(ids[2]),
        "C owns it"
    );
    let stats: Vec<_> = clusters.iter().map(|c| c.stats()).collect();
    let forwarded: u64 = stats.iter().map(|s| s.ops_forwarded).sum();
    let applied: u64 = stats.iter().map(|s| s.ops_applied).sum();
    let not_here: u64 = stats.iter().map(|s| s.ops_not_here).sum();
    assert_eq!(
        (forwarded, not_here, applied),
        (1, 1, 1),
        "forwarded once by A, answered not here by B, applied by C: {stats:?}"
    );
    assert_eq!(
        (stats[0].ops_resent, stats[2].ops_acked, stats[0].ops_acked),
        (1, 1, 1),
        "A sent it again, to C; C's op answered by A, A's resend by C: {stats:?}"
    );
    let v = clusters[2].sim().state(entity.id).expect("C's body").linvel;
    assert!((v[0] - 1.0).abs() < 1e-3, "Δv = J/m, once: {v:?}");
    assert!(clusters.iter().all(|c| c.ops_unanswered() == 0));
}

/// A forwarder that finds the entity its own when the op comes back "not here" applies it: it
/// closed the op's name when it took the op on, which must not read as "applied here
/// already" (in `seam chaos`, a pod catching up after a stall forwarded a write, got the
/// entity back, and dropped the write unsaid as a repeat).
fn forwarded_op_applied_by_its_forwarder_when_the_entity_comes_back(ctx: &TestContext) {
    let (mut clusters, ids, entity) = trio_with_a_ball(ctx, |c| c.exchange = false);
    let mass = 1000.0 * 4.0 / 3.0 * std::f32::consts::PI * 0.125;
    // A hands it to B while C, still seeing A as the owner, writes to it; B hands everything
    // it owns straight back to A, so A's forward finds it gone and A owns it again.
    clusters[1].set_authority_policy(Box::new(HandEverythingTo(ids[0])));
    clusters[0]
        .transfer_authority(entity.id, ids[1])
        .expect("hand over");
    lockstep_round(&mut clusters, TIMEOUT, |index, _, physics| {
        if index == 2 {
            assert_eq!(
                physics.apply_impulse(entity.id, [mass, 0.0, 0.0]),
                Ok(WriteOutcome::Routed)
            );
        }
    })
    .expect("round");
    rounds(&mut clusters, 8);
    assert_eq!(
        clusters[0].sim().info(entity.id).map(|i| i.owner),
        Some(ids[0]),
        "A owns it again"
    );
    let stats: Vec<_> = clusters.iter().map(|c| c.stats()).collect();
    let applied: u64 = stats.iter().map(|s| s.ops_applied).sum();
    let repeated: u64 = stats.iter().map(|s| s.ops_repeated).sum();
    assert_eq!(
        (
            stats[0].ops_forwarded,
            stats[1].ops_not_here,
            applied,
            repeated
        ),
        (1, 1, 1, 0),
        "forwarded by A, answered not here by B, applied by A, not taken for a repeat: \
         {stats:?}"
    );
    let v = clusters[0].sim().state(entity.id).expect("A's body").linvel;
    assert!((v[0] - 1.0).abs() < 1e-3, "Δv = J/m, once: {v:?}");
    assert!(clusters.iter().all(|c| c.ops_unanswered() == 0));
}

/// An authority policy that hands every entity its cluster owns to one neighbour.
struct HandEverythingTo(ClusterId);

impl AuthorityPolicy for HandEverythingTo {
    fn decide(&mut self, view: &AuthorityView<'_>, handoffs: &mut Vec<(EntityId, ClusterId)>) {
        handoffs.extend(view.owned.iter().map(|(state, _)| (state.id, self.0)));
    }
}

/// Scenery is every cluster's and nobody's: each cluster loads it itself, no frame carries
/// it, writes on it are refused, and contacts with it are reported to no one.
fn scenery_is_loaded_everywhere_and_never_replicated(ctx: &TestContext) {
    let mut clusters = pair(ctx, true, |_| {});
    let floor = EntityState::new(
        EntityId::random(),
        ClusterId::random(),
        BodySpec::new(Shape::cuboid(20.0, 0.5, 20.0)).density(1.0),
    )
    .at([0.0, -0.5, 0.0]);
    for cluster in &mut clusters {
        cluster.spawn_scenery(&floor).expect("scenery");
    }
    let crate_ = ball([0.0, 2.0, 0.0], [0.0; 3]);
    clusters[0]
        .spawn_owned(&crate_, BodyRole::Dynamic)
        .expect("spawn");
    let mut refused = None;
    for round in 0..90 {
        lockstep_round(&mut clusters, TIMEOUT, |index, _, physics| {
            if index == 1 && round == 10 {
                refused = Some(physics.apply_impulse(floor.id, [0.0, 100.0, 0.0]));
            }
        })
        .expect("round");
    }
    assert_eq!(
        refused,
        Some(Err(seam_sim::SimError::Scenery(floor.id))),
        "a write on scenery is refused"
    );
    for cluster in &clusters {
        let info = cluster.sim().info(floor.id).expect("every cluster has it");
        assert_eq!(
            (info.owner, info.role),
            (ClusterId::SCENERY, BodyRole::Fixed)
        );
        assert_eq!(cluster.stats().contacts_sent, 0, "nobody to report to");
        assert_eq!(cluster.stats().ops_routed, 0);
    }
    // The ball landed on the floor in its owner's world, and its proxy rests there too.
    let resting = clusters[0]
        .sim()
        .state(crate_.id)
        .expect("A's ball")
        .position[1];
    assert!((resting - 0.5).abs() < 0.02, "on the floor: {resting}");
    // Only the ball travels: each of A's frames stands for one state (listed, or marked
    // unchanged between keyframes), B's for none (the floor's would be a second). Lock-step,
    // a frame goes out per tick and one of the world as it starts.
    let per_frame = |c: &Cluster| (c.stats().states_replicated, c.stats().ticks);
    let ((a, ticks), (b, _)) = (per_frame(&clusters[0]), per_frame(&clusters[1]));
    assert_eq!(
        (a, b),
        (ticks + 1, 0),
        "one state in each of A's frames, none in B's"
    );
}

/// B models A's entities only where their extent — the ball's 0.5 m radius, grown along its
/// velocity by the two ticks before a newer frame replaces its pose — reaches B's region grown
/// by the spread: an entity crossing into it gets a proxy, one leaving loses it.
fn only_the_region_is_modelled(ctx: &TestContext) {
    let mut clusters = pair(ctx, false, |config| {
        config.region = Region {
            min: [0.0, -10.0, -10.0],
            max: [10.0, 10.0, 10.0],
        };
        config.spread = 2.0;
    });
    let far = ball([50.0, 0.0, 0.0], [0.0; 3]);
    let walker = ball([-4.0, 0.0, 0.0], [6.0, 0.0, 0.0]);
    clusters[0]
        .spawn_owned(&far, BodyRole::Dynamic)
        .expect("spawn");
    clusters[0]
        .spawn_owned(&walker, BodyRole::Dynamic)
        .expect("spawn");
    let mut seen = Vec::new();
    for _ in 0..180 {
        rounds(&mut clusters, 1);
        let x = clusters[0]
            .sim()
            .state(walker.id)
            .expect("A's body")
            .position[0];
        seen.push((x, clusters[1].sim().contains(walker.id)));
        assert!(
            !clusters[1].sim().contains(far.id),
            "an entity 40 m outside is not modelled"
        );
    }
    // The walker goes from -4 to +14 m; B models it while its extent, from x - 0.5 to
    // x + 0.5 + 0.2 (6 m/s for two ticks), reaches [-2, 12]: x in [-2.7, 12.5], one tick late.
    let late = 6.0 / 60.0 + 1e-3;
    for &(x, modelled) in &seen {
        if x < -2.7 - late || x > 12.5 + late {
            assert!(!modelled, "modelled at x = {x}");
        }
        if x > -2.7 + late && x < 12.5 - late {
            assert!(modelled, "not modelled at x = {x}");
        }
    }
    assert_eq!(clusters[1].stats().proxies_spawned, 1);
    assert_eq!(clusters[1].stats().proxies_despawned, 1);
}

/// Moves proxies 1 m above the replicated pose and counts its calls.
struct Lifted(std::rc::Rc<std::cell::Cell<u32>>);

impl CustomProxy for Lifted {
    fn update(
        &mut self,
        sim: &mut seam_sim::ClusterSim,
        state: &EntityState,
    ) -> Result<(), seam_sim::SimError> {
        self.0.set(self.0.get() + 1);
        let mut lifted = *state;
        lifted.position[1] += 1.0;
        sim.apply_state(&lifted)
    }
}

fn custom_proxy_hook_moves_proxies(ctx: &TestContext) {
    let mut clusters = pair(ctx, false, |config| config.proxy_mode = ProxyMode::Custom);
    let calls = std::rc::Rc::new(std::cell::Cell::new(0));
    clusters[1].set_custom_proxy(Box::new(Lifted(calls.clone())));
    let entity = ball([0.0; 3], [1.0, 0.0, 0.0]);
    clusters[0]
        .spawn_owned(&entity, BodyRole::Dynamic)
        .expect("spawn");
    rounds(&mut clusters, 10);
    assert!(
        calls.get() >= 8,
        "the hook ran for each update: {}",
        calls.get()
    );
    let info = clusters[1].sim().info(entity.id).expect("proxy");
    assert_eq!(info.role, BodyRole::KinematicPositionBased);
    let y = clusters[1].sim().state(entity.id).expect("proxy").position[1];
    assert!((y - 1.0).abs() < 1e-4, "the hook placed it: y = {y}");
}

/// A hands an entity to B; C, which writes to it, routes to B from then on.
fn third_cluster_routes_to_the_new_owner(ctx: &TestContext) {
    let (mut clusters, ids, entity) = trio_with_a_ball(ctx, |_| {});
    clusters[0]
        .transfer_authority(entity.id, ids[1])
        .expect("hand over");
    rounds(&mut clusters, 3);
    assert_eq!(
        clusters[2].sim().info(entity.id).expect("C's proxy").owner,
        ids[1]
    );
    let mass = 1000.0 * 4.0 / 3.0 * std::f32::consts::PI * 0.125;
    lockstep_round(&mut clusters, TIMEOUT, |index, _, physics| {
        if index == 2 {
            physics
                .apply_impulse(entity.id, [0.0, 0.0, mass])
                .expect("routed");
        }
    })
    .expect("round");
    rounds(&mut clusters, 2);
    let v = clusters[1].sim().state(entity.id).expect("B's body").linvel[2];
    assert!(
        (v - 1.0).abs() < 1e-3,
        "B, the new owner, applied C's push once: {v}"
    );
    assert_eq!(clusters[1].stats().ops_applied, 1);
    assert_eq!(clusters[0].stats().ops_not_here, 0, "nothing went to A");
}

/// Every applied op reports when it was issued, published, received and applied, in that
/// order, on the host clock, and the ticks it took.
fn routed_ops_carry_their_stage_times(ctx: &TestContext) {
    let mut clusters = pair(ctx, false, |_| {});
    clusters[0].keep_events();
    let target = ball([0.0; 3], [0.0; 3]);
    clusters[0]
        .spawn_owned(&target, BodyRole::Dynamic)
        .expect("spawn");
    rounds(&mut clusters, 2);
    let before = seam_proxy::monotonic_ns();
    for _ in 0..5 {
        lockstep_round(&mut clusters, TIMEOUT, |index, _, physics| {
            if index == 1 {
                physics
                    .apply_impulse(target.id, [1.0, 0.0, 0.0])
                    .expect("routed");
                physics.wake(target.id).expect("routed");
            }
        })
        .expect("round");
    }
    rounds(&mut clusters, 2);
    let after = seam_proxy::monotonic_ns();
    let events = clusters[0].take_events();
    let timings: Vec<seam_proxy::OpTiming> = events
        .iter()
        .filter_map(|e| match e.event {
            seam_proxy::ClusterEvent::OpApplied { timing, .. } => Some(timing),
            _ => None,
        })
        .collect();
    assert_eq!(timings.len(), 10);
    assert_eq!(
        clusters[0].stats().ops_applied,
        10,
        "the counters read the same stream"
    );
    for t in &timings {
        assert!(before <= t.issued_ns, "{t:?}");
        assert!(t.issued_ns <= t.published_ns, "{t:?}");
        assert!(t.published_ns <= t.received_ns, "{t:?}");
        assert!(t.received_ns <= t.applied_ns, "{t:?}");
        assert!(t.applied_ns <= after, "{t:?}");
        // In lock-step B writes at its tick n and A applies it before its step of tick n.
        assert_eq!(t.applied_tick, t.issued_tick, "{t:?}");
    }
    assert!(clusters[0].take_events().is_empty(), "taken once");
}
