//! Real bodies across the seam (issue 37, item 6), on shared memory and on Redis, two clusters
//! in lock-step against one world holding everything:
//!
//! - catalog shapes (a convex hull, a compound) and materials (an icy crate, a grippy one, a
//!   bouncy ball, a damped one) on a heightfield both clusters load as scenery, crossing the
//!   seam as in one world, their whole spec (material, groups, sensor) carried to the other
//!   side; the materials matter (the icy crate slides over the seam, the grippy one holds);
//! - collision groups: a ghost in a group of its own falls through a crate owned across the
//!   seam, as in one world, while a plain ball lands on it;
//! - a sensor owned by one cluster reports a ball of the other entering and leaving it, once
//!   each on each side, and pushes nothing;
//! - a body whose catalog shape the neighbour never registered is refused there (counted),
//!   never simulated as something else; the neighbour says so, and the owner hands it nowhere
//!   near it: owned by its owner at every tick.

use std::time::Duration;

use seam_proxy::{AuthorityMode, Cluster, ClusterError, lockstep_round};
use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, Motion, Shape};
use seam_sim::{
    BodyRole, ClusterSim, ContactEvent, LocalOnly, Part, ShapeCatalog, ShapeDef, SimConfig,
};
use seam_tests::{TestContext, row_configs};

seam_tests::backend_tests!(
    [shm: Shm, redis: Redis],
    [
        catalog_shapes_and_materials_cross_the_seam_as_in_one_world,
        a_ghost_passes_through_what_its_groups_exclude_across_the_seam,
        a_sensor_reports_a_body_of_the_other_side_entering_and_leaving,
        a_shape_the_neighbour_never_registered_is_refused_and_never_lost
    ]
);

const TIMEOUT: Duration = Duration::from_secs(10);

/// West ([-30, 0]) and east ([0, 30]) on `url`, each on the world map, spread 4 m.
fn pair(url: &str, gravity: [f32; 3], authority: AuthorityMode) -> Vec<Cluster> {
    row_configs(url, &[(-30.0, 0.0), (0.0, 30.0)])
        .into_iter()
        .map(|mut config| {
            config.gravity = gravity;
            config.spread = 4.0;
            config.authority = authority;
            Cluster::new(config).expect("cluster")
        })
        .collect()
}

fn rock() -> ShapeDef {
    ShapeDef::ConvexHull {
        points: vec![
            [0.5, 0.0, 0.1],
            [-0.45, 0.1, 0.35],
            [0.1, 0.0, -0.5],
            [-0.3, -0.1, -0.35],
            [0.15, 0.45, 0.0],
            [-0.1, -0.45, 0.1],
            [0.35, 0.2, 0.4],
            [-0.4, 0.25, -0.2],
        ],
    }
}

fn dumbbell() -> ShapeDef {
    let part = |x: f32, shape| Part {
        position: [x, 0.0, 0.0],
        rotation: [0.0, 0.0, 0.0, 1.0],
        shape,
    };
    ShapeDef::Compound {
        parts: vec![
            part(-0.6, Shape::ball(0.3)),
            part(0.6, Shape::ball(0.3)),
            Part {
                rotation: [
                    0.0,
                    0.0,
                    std::f32::consts::FRAC_1_SQRT_2,
                    std::f32::consts::FRAC_1_SQRT_2,
                ],
                ..part(0.0, Shape::capsule(0.5, 0.1))
            },
        ],
    }
}

/// A slope falling 0.25 m a metre from west to east, 40 m by 20 m, across the seam.
fn hills() -> ShapeDef {
    let (rows, columns) = (5u32, 9u32);
    let heights = (0..rows)
        .flat_map(|_| (0..columns).map(|c| 5.0 - 10.0 * c as f32 / (columns - 1) as f32))
        .collect();
    ShapeDef::HeightField {
        heights,
        rows,
        columns,
        size: [40.0, 1.0, 20.0],
    }
}

/// The ground's height at `x`.
fn ground(x: f32) -> f32 {
    -0.25 * x
}

/// The named bodies west owns at the start, with their specs resolved in `catalog`.
fn bodies(catalog: &mut ShapeCatalog, west: ClusterId) -> Vec<(&'static str, EntityState)> {
    let rock = catalog.add(rock()).expect("a hull");
    let dumbbell = catalog.add(dumbbell()).expect("a compound");
    let on = |x: f32, z: f32, lift: f32| [x, ground(x) + lift, z];
    let body = |name: &'static str, spec: BodySpec, at: [f32; 3]| {
        (
            name,
            EntityState::new(EntityId::named("bodies", name), west, spec).at(at),
        )
    };
    vec![
        body(
            "rock",
            BodySpec::new(rock).density(800.0).friction(0.3),
            on(-4.0, -7.0, 1.0),
        ),
        body(
            "dumbbell",
            BodySpec::new(dumbbell).density(500.0),
            on(-4.0, -3.0, 0.6),
        ),
        body(
            "icy crate",
            BodySpec::new(Shape::cuboid(0.5, 0.5, 0.5)).friction(0.0),
            on(-3.0, 1.0, 0.75),
        ),
        body(
            "grippy crate",
            BodySpec::new(Shape::cuboid(0.5, 0.5, 0.5)).friction(1.0),
            on(-3.0, 4.0, 0.75),
        ),
        body(
            "bouncy ball",
            BodySpec::new(Shape::ball(0.3)).restitution(0.9),
            on(-2.0, -5.5, 3.0),
        ),
        body(
            "damped ball",
            BodySpec::new(Shape::ball(0.3)).damping(3.0, 3.0),
            on(-3.0, 7.5, 0.4),
        ),
    ]
}

/// The terrain every world loads: the hills, by content hash.
fn terrain(catalog: &mut ShapeCatalog) -> EntityState {
    let shape = catalog.add(hills()).expect("a heightfield");
    EntityState::new(
        EntityId::named("bodies", "hills"),
        ClusterId::SCENERY,
        BodySpec::new(shape).motion(Motion::Still).friction(0.2),
    )
}

const TICKS: usize = 180;

/// Each body's position after `TICKS` in one world, and the bouncy ball's highest point after
/// it first fell below 1 m above the ground.
fn one_world() -> (Vec<[f32; 3]>, f32) {
    let here = ClusterId::random();
    let mut sim = ClusterSim::new(SimConfig::new(here));
    let mut catalog = ShapeCatalog::default();
    for def in [rock(), dumbbell(), hills()] {
        sim.register_shape(def).expect("registered");
    }
    sim.spawn(&terrain(&mut catalog), BodyRole::Fixed)
        .expect("terrain");
    let bodies = bodies(&mut catalog, here);
    for (_, state) in &bodies {
        sim.spawn(state, BodyRole::Dynamic).expect("body");
    }
    let ball = bodies[4].1.id;
    let mut bounce = Bounce::default();
    for _ in 0..TICKS {
        sim.run_user(&mut LocalOnly, |_, _| ());
        sim.step();
        bounce.see(sim.state(ball).expect("the ball").position);
    }
    let at = bodies
        .iter()
        .map(|(_, s)| sim.state(s.id).expect("there").position)
        .collect();
    (at, bounce.highest)
}

/// The bouncy ball's highest point above the ground after it first came down near it.
#[derive(Default)]
struct Bounce {
    landed: bool,
    highest: f32,
}

impl Bounce {
    fn see(&mut self, at: [f32; 3]) {
        let above = at[1] - ground(at[0]);
        self.landed |= above < 0.5;
        if self.landed {
            self.highest = self.highest.max(above);
        }
    }
}

fn distance(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f32>().sqrt()
}

/// Loads the catalog and terrain into both clusters and spawns west's bodies.
fn load(clusters: &mut [Cluster]) -> Vec<(&'static str, EntityState)> {
    let west = clusters[0].id();
    let mut catalog = ShapeCatalog::default();
    let terrain = terrain(&mut catalog);
    for cluster in clusters.iter_mut() {
        for def in [rock(), dumbbell(), hills()] {
            cluster.register_shape(def).expect("registered");
        }
        cluster.spawn_scenery(&terrain).expect("terrain");
    }
    let bodies = bodies(&mut catalog, west);
    for (_, state) in &bodies {
        clusters[0]
            .spawn_owned(state, BodyRole::Dynamic)
            .expect("west's body");
    }
    bodies
}

/// The one cluster owning `id` between ticks.
fn owner(clusters: &[Cluster], id: EntityId) -> usize {
    let owners: Vec<usize> = (0..clusters.len())
        .filter(|&i| clusters[i].owns(id))
        .collect();
    assert_eq!(owners.len(), 1, "one owner of {id}: {owners:?}");
    owners[0]
}

fn catalog_shapes_and_materials_cross_the_seam_as_in_one_world(ctx: &TestContext) {
    let (reference, reference_bounce) = one_world();
    let mut clusters = pair(&ctx.url(), [0.0, -9.81, 0.0], AuthorityMode::default());
    let bodies = load(&mut clusters);
    let mut bounce = Bounce::default();
    for _ in 0..TICKS {
        lockstep_round(&mut clusters, TIMEOUT, |_, _, _| {}).expect("round");
        let ball = bodies[4].1.id;
        let at = clusters[owner(&clusters, ball)]
            .sim()
            .state(ball)
            .expect("ball");
        bounce.see(at.position);
        for (_, state) in &bodies {
            owner(&clusters, state.id);
        }
    }
    for ((name, state), one) in bodies.iter().zip(&reference) {
        let i = owner(&clusters, state.id);
        let split = clusters[i].sim().state(state.id).expect("owned");
        let off = distance(split.position, *one);
        assert!(
            off <= 0.05,
            "{name}: {off} m from one world (split {:?}, one world {one:?})",
            split.position
        );
        // The other side models it with the same body: shape, material, groups, sensor.
        if let Some(other) = clusters[1 - i].sim().state(state.id) {
            let (a, b) = (other.body, split.body);
            assert_eq!(
                (a.shape, a.material, a.groups, a.sensor),
                (b.shape, b.material, b.groups, b.sensor),
                "{name}: proxied with its whole spec"
            );
        }
    }
    // The materials matter: the icy crate slid over the seam to east, the grippy one held.
    let icy = bodies[2].1.id;
    assert_eq!(owner(&clusters, icy), 1, "the icy crate crossed to east");
    assert!(
        reference[2][0] > 1.0 && reference[3][0] < -2.5,
        "{reference:?}"
    );
    // The bouncy ball bounced as high as in one world, well above a dead drop.
    assert!(
        reference_bounce > 0.6,
        "one world's bounce {reference_bounce}"
    );
    assert!(
        (bounce.highest - reference_bounce).abs() <= 0.02,
        "bounce {} against one world's {reference_bounce}",
        bounce.highest
    );
    // The damped ball crept down the slope that took the undamped bouncy one metres on.
    assert!(
        reference[5][0] - (-3.0) < 2.0 && reference[4][0] - (-2.0) > 4.0,
        "{reference:?}"
    );
}

fn a_ghost_passes_through_what_its_groups_exclude_across_the_seam(ctx: &TestContext) {
    // East owns a wide crate on the seam; west drops a ghost (group 2, meeting all but group 1)
    // and a plain ball onto it from just west of the seam. No ground: the ghost falls on.
    let mut clusters = pair(&ctx.url(), [0.0, -9.81, 0.0], AuthorityMode::Scripted);
    let (west, east) = (clusters[0].id(), clusters[1].id());
    let slab = EntityState::new(
        EntityId::random(),
        east,
        BodySpec::new(Shape::cuboid(2.0, 0.25, 2.0)).groups(1, u32::MAX),
    )
    .at([0.5, 0.0, 0.0]);
    clusters[1]
        .spawn_owned(&slab, BodyRole::Fixed)
        .expect("slab");
    let ghost = EntityState::new(
        EntityId::random(),
        west,
        BodySpec::new(Shape::ball(0.2)).groups(2, !1),
    )
    .at([-0.5, 2.0, -1.0]);
    let ball = EntityState::new(EntityId::random(), west, BodySpec::new(Shape::ball(0.2)))
        .at([-0.5, 2.0, 1.0]);
    for body in [&ghost, &ball] {
        clusters[0]
            .spawn_owned(body, BodyRole::Dynamic)
            .expect("body");
    }
    for _ in 0..90 {
        lockstep_round(&mut clusters, TIMEOUT, |_, _, _| {}).expect("round");
    }
    let y = |id| clusters[0].sim().state(id).expect("west's").position[1];
    assert!(
        y(ghost.id) < -5.0,
        "the ghost fell through the slab: y = {}",
        y(ghost.id)
    );
    assert!(
        (y(ball.id) - 0.45).abs() < 0.05,
        "the ball rests on the slab: y = {}",
        y(ball.id)
    );
}

fn a_sensor_reports_a_body_of_the_other_side_entering_and_leaving(ctx: &TestContext) {
    // No gravity, scripted authority: east owns a sensor gate standing in west's region
    // (x in [-3, -1]); west's ball rolls through it at 4 m/s.
    let mut clusters = pair(&ctx.url(), [0.0; 3], AuthorityMode::Scripted);
    let (west, east) = (clusters[0].id(), clusters[1].id());
    let gate = EntityState::new(
        EntityId::random(),
        east,
        BodySpec::new(Shape::cuboid(1.0, 1.0, 1.0)).sensor(true),
    )
    .at([-2.0, 0.0, 0.0]);
    clusters[1]
        .spawn_owned(&gate, BodyRole::Fixed)
        .expect("gate");
    let ball = EntityState::new(EntityId::random(), west, BodySpec::new(Shape::ball(0.25)))
        .at([-8.0, 0.0, 0.0])
        .velocity([4.0, 0.0, 0.0]);
    clusters[0]
        .spawn_owned(&ball, BodyRole::Dynamic)
        .expect("ball");
    let mut seen: [Vec<ContactEvent>; 2] = [Vec::new(), Vec::new()];
    for _ in 0..120 {
        lockstep_round(&mut clusters, TIMEOUT, |index, context, _| {
            seen[index].extend(
                context
                    .contacts()
                    .iter()
                    .filter(|c| [c.a, c.b].contains(&gate.id) && [c.a, c.b].contains(&ball.id)),
            );
        })
        .expect("round");
    }
    for (side, events) in ["west", "east"].iter().zip(&seen) {
        let started: Vec<bool> = events.iter().map(|c| c.started).collect();
        assert_eq!(
            started,
            vec![true, false],
            "{side}: the ball entered and left the gate, once each: {events:?}"
        );
    }
    let after = clusters[0].sim().state(ball.id).expect("west's ball");
    assert_eq!(after.linvel, [4.0, 0.0, 0.0], "a sensor pushes nothing");
    assert!(after.position[0] > 0.0, "{after:?}");
}

fn a_shape_the_neighbour_never_registered_is_refused_and_never_lost(ctx: &TestContext) {
    // West registers the rock; east does not. The rock flies east over the seam.
    let mut clusters = pair(&ctx.url(), [0.0; 3], AuthorityMode::default());
    let rock = clusters[0].register_shape(rock()).expect("west registers");
    let state = EntityState::new(
        EntityId::random(),
        clusters[0].id(),
        BodySpec::new(rock).density(800.0),
    )
    .at([-6.0, 0.0, 0.0])
    .velocity([6.0, 0.0, 0.0]);
    clusters[0]
        .spawn_owned(&state, BodyRole::Dynamic)
        .expect("west's rock");
    // East refuses the rock's states as it comes into view and tells west, which then
    // hands it nowhere near east: one owner, west, at every tick.
    for tick in 0..240 {
        lockstep_round(&mut clusters, TIMEOUT, |_, _, _| {}).expect("round");
        assert_eq!(
            owner(&clusters, state.id),
            0,
            "west owns the rock at tick {tick}"
        );
    }
    let west = clusters[0].stats();
    assert_eq!(
        (west.handoffs_out, west.handoffs_returned),
        (0, 0),
        "never handed to east: {west}"
    );
    let east = clusters[1].id();
    let refused = clusters[0].transfer_authority(state.id, east);
    assert!(
        matches!(&refused, Err(ClusterError::Transfer { reason, .. }) if reason.contains("cannot model")),
        "game code's hand-off to east is refused with the reason: {refused:?}"
    );
    assert!(
        !clusters[1].sim().contains(state.id),
        "east never simulates a shape it does not know as something else"
    );
    assert!(
        clusters[1].stats().states_rejected > 0,
        "east counted the states it refused: {:?}",
        clusters[1].stats()
    );
    let x = clusters[0].sim().state(state.id).expect("west's").position[0];
    assert!(x > 10.0, "and it flew on: x = {x}");
}
