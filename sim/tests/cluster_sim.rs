//! One cluster's world: spawning, roles, writes, validation, routing, joints, queries and
//! contacts, on real Rapier worlds.

use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, PhysicsOp, Shape};
use seam_sim::{
    BodyRole, ClusterSim, JointSpec, LocalOnly, SimConfig, SimError, WriteOutcome, WriteRouter,
};

const HERE: ClusterId = ClusterId(uuid::Uuid::from_u128(1));
const THERE: ClusterId = ClusterId(uuid::Uuid::from_u128(2));

fn ball(id: u128, owner: ClusterId, position: [f32; 3], radius: f32) -> EntityState {
    let body = BodySpec::new(Shape::ball(radius));
    EntityState::new(EntityId::from_u128(id), owner, body).at(position)
}

fn cuboid(id: u128, owner: ClusterId, position: [f32; 3], half: [f32; 3]) -> EntityState {
    let body = BodySpec::new(Shape::cuboid(half[0], half[1], half[2]));
    EntityState::new(EntityId::from_u128(id), owner, body).at(position)
}

fn sim() -> ClusterSim {
    ClusterSim::new(SimConfig::new(HERE))
}

/// Every state of the world, as raw bits, to compare worlds exactly.
fn snapshot(sim: &ClusterSim) -> Vec<(EntityId, [u32; 13])> {
    sim.entities()
        .map(|(id, _)| (id, sim.state(id).expect("listed").motion_bits()))
        .collect()
}

#[test]
fn spawn_and_despawn() {
    let mut sim = sim();
    let state = ball(1, HERE, [1.0, 2.0, 3.0], 0.5);
    sim.spawn(&state, BodyRole::Dynamic).expect("spawn");
    assert_eq!(
        sim.spawn(&state, BodyRole::Dynamic),
        Err(SimError::DuplicateEntity(state.id))
    );
    assert_eq!(
        sim.state(state.id).expect("there").position,
        [1.0, 2.0, 3.0]
    );
    assert_eq!(
        sim.despawn(state.id).expect("despawn").position,
        [1.0, 2.0, 3.0]
    );
    assert!(sim.is_empty());
    assert_eq!(
        sim.despawn(state.id),
        Err(SimError::UnknownEntity(state.id))
    );
}

#[test]
fn invalid_states_are_refused() {
    let mut sim = sim();
    let mut nan = ball(1, HERE, [f32::NAN, 0.0, 0.0], 0.5);
    assert!(matches!(
        sim.spawn(&nan, BodyRole::Dynamic),
        Err(SimError::NonFinite { .. })
    ));
    nan.position = [0.0; 3];
    nan.rotation = [0.0, 0.0, 0.0, 2.0];
    assert!(matches!(
        sim.spawn(&nan, BodyRole::Dynamic),
        Err(SimError::BadRotation { .. })
    ));
    let flat = ball(2, HERE, [0.0; 3], 0.0);
    assert!(matches!(
        sim.spawn(&flat, BodyRole::Dynamic),
        Err(SimError::BadShape { .. })
    ));
    assert!(sim.is_empty());
}

#[test]
fn roles_change_in_place_carrying_velocity() {
    let mut sim = sim();
    let mut state = ball(1, HERE, [0.0, 0.0, 0.0], 0.5);
    state.linvel = [3.0, 0.0, 0.0];
    sim.spawn(&state, BodyRole::Dynamic).expect("spawn");
    sim.set_role(state.id, BodyRole::KinematicVelocityBased)
        .expect("role");
    assert_eq!(sim.state(state.id).expect("there").linvel, [3.0, 0.0, 0.0]);
    sim.step();
    let moved = sim.state(state.id).expect("there").position[0];
    assert!(
        (moved - 3.0 / 60.0).abs() < 1e-5,
        "kinematic keeps moving: {moved}"
    );
    sim.set_role(state.id, BodyRole::Dynamic).expect("role");
    assert_eq!(sim.state(state.id).expect("there").linvel[0], 3.0);
    // Rapier zeroes the velocity of a body made Fixed.
    sim.set_role(state.id, BodyRole::Fixed).expect("role");
    assert_eq!(sim.state(state.id).expect("there").linvel, [0.0; 3]);
    assert_eq!(sim.info(state.id).expect("there").role, BodyRole::Fixed);
    assert_eq!(sim.len(), 1, "still one body");
}

#[test]
fn impulse_changes_velocity_by_impulse_over_mass() {
    let mut sim = ClusterSim::new(SimConfig {
        gravity: [0.0; 3],
        ..SimConfig::new(HERE)
    });
    let state = ball(1, HERE, [0.0; 3], 0.5);
    sim.spawn(&state, BodyRole::Dynamic).expect("spawn");
    let mass = 1000.0 * 4.0 / 3.0 * std::f32::consts::PI * 0.125;
    let outcome = sim
        .run_user(&mut LocalOnly, |_, physics| {
            physics.apply_impulse(state.id, [mass * 2.0, 0.0, 0.0])
        })
        .expect("write");
    assert_eq!(outcome, WriteOutcome::Applied);
    sim.step();
    let v = sim.state(state.id).expect("there").linvel[0];
    assert!((v - 2.0).abs() < 1e-3, "Δv = J/m = 2, got {v}");
}

#[test]
fn bad_writes_leave_the_world_bit_for_bit_unchanged() {
    let mut sim = sim();
    for i in 0..5 {
        sim.spawn(
            &ball(i + 1, HERE, [i as f32 * 2.0, 1.0, 0.0], 0.5),
            BodyRole::Dynamic,
        )
        .expect("spawn");
    }
    sim.step();
    let before = snapshot(&sim);
    let target = EntityId::from_u128(1);
    let unknown = EntityId::from_u128(999);
    sim.run_user(&mut LocalOnly, |_, physics| {
        let bad = [
            physics.apply_impulse(target, [f32::NAN, 0.0, 0.0]),
            physics.apply_force(target, [0.0, f32::INFINITY, 0.0]),
            physics.apply_torque_impulse(target, [0.0, 0.0, f32::NEG_INFINITY]),
            physics.set_translation(target, [f32::NAN; 3]),
            physics.set_linvel(target, [1.0, f32::NAN, 1.0]),
            physics.set_angvel(target, [f32::INFINITY, 0.0, 0.0]),
            physics.apply_impulse(unknown, [1.0, 0.0, 0.0]),
            physics.wake(unknown),
            physics.apply_impulse(target, [1.0e30, 0.0, 0.0]),
            physics.set_linvel(target, [0.0, -2.0e6, 0.0]),
        ];
        for result in bad {
            assert!(result.is_err(), "{result:?}");
        }
        assert!(matches!(
            physics.apply_impulse(target, [f32::NAN, 0.0, 0.0]),
            Err(SimError::NonFinite {
                what: "impulse",
                ..
            })
        ));
        assert!(matches!(
            physics.apply_impulse(target, [1.0e30, 0.0, 0.0]),
            Err(SimError::BeyondBound {
                what: "impulse",
                bound: 1.0e6,
                ..
            })
        ));
        assert_eq!(
            physics.sleep(unknown),
            Err(SimError::UnknownEntity(unknown))
        );
    });
    assert!(
        sim.apply_op(&PhysicsOp::SetLinvel {
            target,
            linvel: [f32::NAN; 3]
        })
        .is_err()
    );
    assert_eq!(snapshot(&sim), before, "nothing moved");
}

#[derive(Default)]
struct Recorder(Vec<(ClusterId, PhysicsOp)>);

impl WriteRouter for Recorder {
    fn route(&mut self, owner: ClusterId, op: PhysicsOp) -> Result<(), SimError> {
        self.0.push((owner, op));
        Ok(())
    }
}

#[test]
fn writes_on_remote_entities_go_to_the_router() {
    let mut sim = sim();
    let remote = ball(1, THERE, [0.0; 3], 0.5);
    let local = ball(2, HERE, [5.0, 0.0, 0.0], 0.5);
    sim.spawn(&remote, BodyRole::Fixed).expect("proxy");
    sim.spawn(&local, BodyRole::Dynamic).expect("local");
    let before = snapshot(&sim);
    let mut router = Recorder::default();
    sim.run_user(&mut router, |_, physics| {
        assert_eq!(
            physics.apply_impulse(remote.id, [1.0, 0.0, 0.0]),
            Ok(WriteOutcome::Routed)
        );
        assert_eq!(physics.wake(remote.id), Ok(WriteOutcome::Routed));
        // Invalid writes are refused before routing.
        assert!(physics.apply_impulse(remote.id, [f32::NAN; 3]).is_err());
        assert!(
            physics
                .apply_impulse(remote.id, [0.0, 1.0e30, 0.0])
                .is_err(),
            "a write beyond the bound is refused, not routed"
        );
    });
    assert_eq!(
        router.0,
        vec![
            (
                THERE,
                PhysicsOp::Impulse {
                    target: remote.id,
                    impulse: [1.0, 0.0, 0.0]
                }
            ),
            (THERE, PhysicsOp::Wake { target: remote.id }),
        ]
    );
    assert_eq!(
        snapshot(&sim),
        before,
        "routed writes do not touch the proxy"
    );
    // A world standing alone refuses them.
    let refused = sim.run_user(&mut LocalOnly, |_, physics| physics.wake(remote.id));
    assert_eq!(
        refused,
        Err(SimError::NotOwned {
            entity: remote.id,
            owner: THERE
        })
    );
}

#[test]
fn joints_only_between_entities_owned_here() {
    let mut sim = sim();
    let (a, b) = (
        ball(1, HERE, [0.0; 3], 0.5),
        ball(2, HERE, [2.0, 0.0, 0.0], 0.5),
    );
    let remote = ball(3, THERE, [4.0, 0.0, 0.0], 0.5);
    for (state, role) in [
        (a, BodyRole::Dynamic),
        (b, BodyRole::Dynamic),
        (remote, BodyRole::Fixed),
    ] {
        sim.spawn(&state, role).expect("spawn");
    }
    let spec = JointSpec::Spherical {
        anchor_a: [1.0, 0.0, 0.0],
        anchor_b: [-1.0, 0.0, 0.0],
    };
    sim.run_user(&mut LocalOnly, |_, physics| {
        assert_eq!(
            physics.create_joint(a.id, remote.id, spec),
            None,
            "across clusters"
        );
        assert_eq!(
            physics.create_joint(remote.id, b.id, spec),
            None,
            "across clusters"
        );
        assert_eq!(physics.create_joint(a.id, a.id, spec), None, "to itself");
        let bad = JointSpec::Revolute {
            axis: [0.0; 3],
            anchor_a: [0.0; 3],
            anchor_b: [0.0; 3],
        };
        assert_eq!(physics.create_joint(a.id, b.id, bad), None, "zero axis");
        let joint = physics
            .create_joint(a.id, b.id, spec)
            .expect("both owned here");
        assert!(physics.remove_joint(joint));
        assert!(!physics.remove_joint(joint));
        physics.create_joint(a.id, b.id, spec).expect("again");
    });
    // The joint holds the pair together while one is pushed.
    sim.run_user(&mut LocalOnly, |_, physics| {
        physics.set_linvel(a.id, [0.0, 0.0, 5.0])
    })
    .expect("write");
    for _ in 0..60 {
        sim.step();
    }
    let (pa, pb) = (
        sim.state(a.id).expect("a").position,
        sim.state(b.id).expect("b").position,
    );
    let distance =
        ((pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2) + (pa[2] - pb[2]).powi(2)).sqrt();
    assert!(
        (distance - 2.0).abs() < 0.05,
        "jointed bodies stay 2 m apart: {distance}"
    );
    sim.despawn(b.id).expect("despawn takes its joints with it");
}

#[test]
fn raycasts_hit_proxies_at_once_and_where_they_moved() {
    let mut sim = sim();
    let shooter = ball(1, HERE, [0.0, 0.0, 0.0], 0.5);
    let mut target = cuboid(2, THERE, [10.0, 0.0, 0.0], [0.5, 2.0, 2.0]);
    sim.spawn(&shooter, BodyRole::Dynamic).expect("spawn");
    sim.spawn(&target, BodyRole::Fixed).expect("proxy");
    // No step yet: the proxy spawned this tick must already be hit.
    let hit = sim
        .run_user(&mut LocalOnly, |_, physics| {
            physics.raycast([0.0; 3], [1.0, 0.0, 0.0], 100.0, Some(shooter.id))
        })
        .expect("hits the proxy");
    assert_eq!(hit.entity, target.id);
    assert!(
        (hit.toi - 9.5).abs() < 1e-4,
        "hits the near face: {}",
        hit.toi
    );
    assert_eq!(hit.normal, [-1.0, 0.0, 0.0]);

    // The proxy moves with replication; the next query sees it where it is now.
    target.position = [20.0, 0.0, 0.0];
    sim.apply_state(&target).expect("update");
    let hit = sim
        .run_user(&mut LocalOnly, |_, physics| {
            physics.raycast([0.0; 3], [1.0, 0.0, 0.0], 100.0, Some(shooter.id))
        })
        .expect("hits the moved proxy");
    assert!((hit.toi - 19.5).abs() < 1e-4, "{}", hit.toi);
    // Out of range, bad input: no hit, no panic.
    sim.run_user(&mut LocalOnly, |_, physics| {
        assert_eq!(
            physics.raycast([0.0; 3], [1.0, 0.0, 0.0], 5.0, Some(shooter.id)),
            None
        );
        assert_eq!(
            physics.raycast([f32::NAN; 3], [1.0, 0.0, 0.0], 5.0, None),
            None
        );
    });
}

#[test]
fn shape_queries_return_entity_ids() {
    let mut sim = sim();
    for (i, x) in [0.0f32, 3.0, 30.0].iter().enumerate() {
        let owner = if i == 1 { THERE } else { HERE };
        sim.spawn(
            &ball(i as u128 + 1, owner, [*x, 0.0, 0.0], 0.5),
            BodyRole::Fixed,
        )
        .expect("spawn");
    }
    let hits = sim.run_user(&mut LocalOnly, |_, physics| {
        physics.intersections_with_shape(
            &Shape::Ball { radius: 5.0 },
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        )
    });
    assert_eq!(hits, vec![EntityId::from_u128(1), EntityId::from_u128(2)]);
}

#[test]
fn contacts_with_fixed_and_kinematic_bodies_are_reported() {
    let mut sim = sim();
    let ground = cuboid(1, THERE, [0.0, -0.5, 0.0], [10.0, 0.5, 10.0]);
    let platform = cuboid(2, THERE, [5.0, 2.0, 0.0], [1.0, 0.1, 1.0]);
    let falling = ball(3, HERE, [0.0, 1.0, 0.0], 0.5);
    let dropping = ball(4, HERE, [5.0, 3.0, 0.0], 0.5);
    sim.spawn(&ground, BodyRole::Fixed).expect("fixed proxy");
    sim.spawn(&platform, BodyRole::KinematicVelocityBased)
        .expect("kinematic proxy");
    sim.spawn(&falling, BodyRole::Dynamic).expect("spawn");
    sim.spawn(&dropping, BodyRole::Dynamic).expect("spawn");
    let mut started = Vec::new();
    for _ in 0..120 {
        sim.step();
        let seen = sim.run_user(&mut LocalOnly, |context, _| context.contacts().to_vec());
        started.extend(seen.into_iter().filter(|c| c.started));
    }
    let touched = |x: EntityId, y: EntityId| {
        started
            .iter()
            .any(|c| (c.a == x && c.b == y) || (c.a == y && c.b == x))
    };
    assert!(
        touched(falling.id, ground.id),
        "dynamic on Fixed: {started:?}"
    );
    assert!(
        touched(dropping.id, platform.id),
        "dynamic on kinematic: {started:?}"
    );
}

fn projectile_scene(
    ccd: bool,
    speed: f32,
    cap: f32,
    wall_role: BodyRole,
) -> (ClusterSim, EntityId, EntityId) {
    let mut sim = ClusterSim::new(SimConfig {
        gravity: [0.0; 3],
        max_linear_velocity: cap,
        ..SimConfig::new(HERE)
    });
    // A 10 cm wall 10 m away: inside the 16.7 m a 1000 m/s bullet travels in one 60 Hz step.
    let wall = cuboid(1, THERE, [10.0, 0.0, 0.0], [0.05, 2.0, 2.0]);
    let mut bullet = ball(2, HERE, [0.0; 3], 0.05);
    bullet.linvel = [speed, 0.0, 0.0];
    bullet.body.ccd = ccd;
    bullet.body.density = 10_000.0;
    sim.spawn(&wall, wall_role).expect("wall");
    sim.spawn(&bullet, BodyRole::Dynamic).expect("bullet");
    (sim, bullet.id, wall.id)
}

/// Steps ten times; returns whether the bullet's contact with the wall started, and its speed
/// at the end.
fn fire(sim: &mut ClusterSim, bullet: EntityId, wall: EntityId) -> (bool, f32) {
    let mut hit = false;
    for _ in 0..10 {
        sim.step();
        hit |= sim
            .contacts()
            .iter()
            .any(|c| c.started && ((c.a, c.b) == (bullet, wall) || (c.a, c.b) == (wall, bullet)));
    }
    (hit, sim.state(bullet).expect("bullet").linvel[0])
}

#[test]
fn fast_projectile_with_ccd_hits_a_thin_wall() {
    for wall_role in [BodyRole::Fixed, BodyRole::KinematicVelocityBased] {
        let (mut sim, bullet, wall) = projectile_scene(true, 1000.0, 2000.0, wall_role);
        let (hit, speed) = fire(&mut sim, bullet, wall);
        assert!(hit, "1000 m/s with CCD hits a 10 cm {wall_role:?} wall");
        assert!(speed.abs() < 10.0, "and is stopped by it: {speed} m/s");
    }
}

#[test]
fn fast_projectile_without_ccd_tunnels_through_a_kinematic_wall() {
    let (mut sim, bullet, wall) =
        projectile_scene(false, 1000.0, 2000.0, BodyRole::KinematicVelocityBased);
    let (hit, speed) = fire(&mut sim, bullet, wall);
    assert!(
        !hit && speed == 1000.0,
        "the CCD test above must be able to fail"
    );
}

/// Rapier 0.36 sweeps fixed colliders for every fast dynamic body, CCD or not: a Fixed proxy is
/// not tunnelled. (`ccd` extends the sweep to kinematic and dynamic bodies.)
#[test]
fn fast_projectile_without_ccd_still_hits_a_fixed_wall() {
    let (mut sim, bullet, wall) = projectile_scene(false, 1000.0, 2000.0, BodyRole::Fixed);
    assert!(fire(&mut sim, bullet, wall).0);
}

#[test]
fn speed_cap_is_configuration() {
    let (mut sim, bullet, _) = projectile_scene(false, 300.0, 200.0, BodyRole::Fixed);
    sim.step();
    let v = sim.state(bullet).expect("bullet").linvel[0];
    assert!(
        (v - 200.0).abs() < 1e-3,
        "a cap of 200 m/s holds a 300 m/s bullet to 200: {v}"
    );
    let default_cap = SimConfig::new(HERE).max_linear_velocity;
    assert_eq!(default_cap, 400.0, "the default is Rapier's 400 m/s");
    let (mut sim, bullet, _) = projectile_scene(false, 1000.0, default_cap, BodyRole::Fixed);
    sim.step();
    let v = sim.state(bullet).expect("bullet").linvel[0];
    assert!(
        (v - 400.0).abs() < 1e-3,
        "the default cap holds a 1000 m/s bullet to 400 m/s: {v}"
    );
    let (mut sim, bullet, _) = projectile_scene(false, 1000.0, 2000.0, BodyRole::Fixed);
    sim.step();
    assert_eq!(
        sim.state(bullet).expect("bullet").linvel[0],
        1000.0,
        "raised cap"
    );
}

fn run_scene() -> Vec<(EntityId, [u32; 13])> {
    let mut sim = sim();
    sim.spawn(
        &cuboid(1, HERE, [0.0, -0.5, 0.0], [50.0, 0.5, 50.0]),
        BodyRole::Fixed,
    )
    .expect("ground");
    for i in 0..200u32 {
        let (x, z) = ((i % 20) as f32 * 1.1 - 10.0, (i / 20) as f32 * 1.1 - 5.0);
        let y = 1.0 + (i % 7) as f32 * 0.6;
        sim.spawn(
            &ball(100 + i as u128, HERE, [x, y, z], 0.5),
            BodyRole::Dynamic,
        )
        .expect("ball");
    }
    for tick in 0..300u32 {
        sim.run_user(&mut LocalOnly, |context, physics| {
            let ids: Vec<EntityId> = context.entities().map(|(id, _)| id).collect();
            let id = ids[1 + (tick as usize * 7) % (ids.len() - 1)];
            physics.apply_impulse(id, [0.3, 2.0, -0.1]).map(|_| ())
        })
        .expect("impulse");
        sim.step();
    }
    snapshot(&sim)
}

#[test]
fn same_inputs_give_bit_identical_worlds() {
    let (first, second) = (run_scene(), run_scene());
    assert_eq!(first.len(), 201);
    assert!(first == second, "two runs of the same scene differ");
}

#[test]
fn states_land_on_the_right_entity_in_any_order() {
    let mut sim = sim();
    for i in 0..20u128 {
        sim.spawn(
            &ball(i + 1, THERE, [i as f32, 0.0, 0.0], 0.5),
            BodyRole::Fixed,
        )
        .expect("proxy");
    }
    // Despawns move the last entries into the gaps.
    for gone in [3u128, 11, 20] {
        sim.despawn(EntityId::from_u128(gone)).expect("despawn");
    }
    let order = [
        17u128, 1, 2, 19, 5, 4, 6, 7, 12, 8, 9, 10, 13, 14, 15, 16, 18,
    ];
    for round in 0..3 {
        for &i in &order {
            let mut state = ball(i, THERE, [0.0; 3], 0.5);
            state.position = [i as f32 * 10.0 + round as f32, 1.0, 0.0];
            sim.apply_state(&state).expect("apply");
        }
        for &i in &order {
            let position = sim.state(EntityId::from_u128(i)).expect("there").position;
            assert_eq!(
                position,
                [i as f32 * 10.0 + round as f32, 1.0, 0.0],
                "entity {i}"
            );
        }
    }
    let gone = ball(3, THERE, [0.0; 3], 0.5);
    assert_eq!(
        sim.apply_state(&gone),
        Err(SimError::UnknownEntity(gone.id))
    );
}

/// Game code spawns through the handle: checked when asked, added once its code has run (so
/// the tick's own reads do not see it), owned by this cluster whatever the state said, and
/// stepped with the world.
#[test]
fn game_code_spawns_through_the_handle() {
    let mut sim = ClusterSim::new(SimConfig {
        gravity: [0.0; 3],
        ..SimConfig::new(HERE)
    });
    sim.spawn(&ball(1, HERE, [0.0; 3], 0.5), BodyRole::Dynamic)
        .expect("a ball to start with");
    let shot = ball(2, THERE, [5.0, 0.0, 0.0], 0.1).velocity([10.0, 0.0, 0.0]);
    let mut nan = ball(3, HERE, [0.0; 3], 0.1);
    nan.position[1] = f32::NAN;
    sim.run_user(&mut LocalOnly, |context, physics| {
        physics.spawn(&shot, BodyRole::Dynamic).expect("spawned");
        assert_eq!(
            physics.spawn(&shot, BodyRole::Dynamic),
            Err(SimError::DuplicateEntity(shot.id)),
            "asked twice"
        );
        assert_eq!(
            physics.spawn(&ball(1, HERE, [0.0; 3], 0.5), BodyRole::Dynamic),
            Err(SimError::DuplicateEntity(EntityId::from_u128(1))),
            "already in the world"
        );
        assert!(matches!(
            physics.spawn(&nan, BodyRole::Dynamic),
            Err(SimError::NonFinite { .. })
        ));
        assert!(
            context.entity(shot.id).is_none(),
            "not before the code has run"
        );
    });
    let info = sim.info(shot.id).expect("added after the code ran");
    assert_eq!((info.owner, info.role), (HERE, BodyRole::Dynamic));
    assert!(sim.info(nan.id).is_none());
    sim.step();
    let moved = sim.state(shot.id).expect("there").position[0];
    assert!(moved > 5.1, "stepped with the world: x = {moved}");
}

/// A body resting against a proxy of an entity at rest falls asleep as it would in one world,
/// though the proxy is set to every frame its owner sends, each a few nanometres off (Rapier
/// wakes everything near a collider moved from outside a step, however little: a Newton's
/// cradle across a seam never slept, and a strike went down its row a step early); a state
/// that moves still sets the proxy exactly where its owner has it.
#[test]
fn bodies_against_a_proxy_at_rest_fall_asleep() {
    let mut sim = sim();
    let floor = cuboid(1, ClusterId::SCENERY, [0.0, -0.5, 0.0], [10.0, 0.5, 10.0]);
    sim.spawn(&floor, BodyRole::Fixed).expect("floor");
    let own = ball(2, HERE, [0.0, 0.25, 0.0], 0.25);
    sim.spawn(&own, BodyRole::Dynamic).expect("own ball");
    let proxy = ball(3, THERE, [0.5, 0.25, 0.0], 0.25);
    sim.spawn(&proxy, BodyRole::Fixed).expect("proxy");
    let own_id = EntityId::from_u128(2);
    let proxy_id = EntityId::from_u128(3);
    for tick in 0..90u32 {
        // The owner's frames of its ball at rest: where it settles here too (the two worlds
        // solve it alike), give or take 30 nm.
        let jitter = if tick % 2 == 0 { 3.0e-8 } else { -3.0e-8 };
        let mut frame = proxy;
        frame.position = sim.state(proxy_id).expect("proxy").position;
        frame.position[1] += jitter;
        frame.tick = sim.tick();
        sim.apply_state(&frame).expect("frame");
        sim.couple_proxies(BodyRole::Fixed);
        sim.step();
    }
    assert_eq!(
        sim.is_asleep(own_id),
        Some(true),
        "the ball beside the proxy sleeps"
    );
    // A frame that moves the proxy sets it exactly, and wakes what it touches.
    let mut moving = proxy;
    moving.position = [0.6, 0.25, 0.0];
    moving.linvel = [1.0, 0.0, 0.0];
    moving.tick = sim.tick();
    sim.apply_state(&moving).expect("moving frame");
    let state = sim.state(proxy_id).expect("proxy");
    assert_eq!(
        state.position, moving.position,
        "a moving proxy stands where its owner has it"
    );
    sim.couple_proxies(BodyRole::Fixed);
    sim.step();
    assert_eq!(
        sim.is_asleep(own_id),
        Some(false),
        "a moved neighbour wakes the ball"
    );
}
