//! Hand-offs that cannot lose a body (issue 37, item 1), on shared memory and on Redis:
//!
//! - a body is never handed to a neighbour that has not been heard from (on the world map,
//!   never started): game code's `transfer_authority` is refused with the reason, and the
//!   spatial policy keeps the body, which flies on owned;
//! - a neighbour that starts late gets the body once it runs and has heard of it: owned by
//!   exactly one cluster at every tick meanwhile, no jump at the hand-off, and a write from
//!   middle's game code reaches it at its new owner;
//! - a body is handed only to a neighbour that models it (its extent reaches the neighbour's
//!   region and spread on the world map): game code's hand-off of a body far from the
//!   neighbour is refused with the reason, one near it goes;
//! - a hand-off a live neighbour does not take (it does not list the giver as a neighbour, so
//!   never reads its frames) comes back within `neighbour_timeout_ticks`, counted, and the
//!   body moves on as the giver's;
//! - between ticks, every body is owned by exactly one cluster ([`Cluster::owns`]), in the
//!   tick of a hand-off too, lock-step and free-running.

use seam_proxy::{AuthorityMode, Cluster, ClusterConfig, ClusterError, lockstep_round};
use seam_sim::BodyRole;
use seam_sim::wire::{ClusterId, EntityState};
use seam_tests::{TestContext, ball_at, row_configs};

seam_tests::backend_tests!(
    [shm: Shm, redis: Redis],
    [
        a_neighbour_never_started_is_never_handed_a_body,
        a_late_neighbour_gets_the_body_once_it_runs,
        a_body_is_handed_only_to_a_neighbour_that_models_it,
        a_handoff_the_neighbour_does_not_take_comes_back,
        every_body_has_one_owner_at_every_tick_in_lockstep,
        every_body_has_one_owner_at_every_tick_free_running
    ]
);

/// Three clusters in a row along x (west [-30,-10], middle [-10,10], east [10,30]), zero
/// gravity, the default authority policy, on `url`; `neighbours` gives each one's list by index
/// (the world map says middle neighbours both). Returns the configurations.
fn row(
    url: &str,
    neighbours: impl Fn(usize, &[ClusterId; 3]) -> Vec<ClusterId>,
) -> Vec<ClusterConfig> {
    let mut configs = row_configs(url, &[(-30.0, -10.0), (-10.0, 10.0), (10.0, 30.0)]);
    let ids = [0, 1, 2].map(|i| configs[i].cluster_id);
    for (i, config) in configs.iter_mut().enumerate() {
        config.neighbours = neighbours(i, &ids);
        config.spread = 4.0;
    }
    configs
}

/// The neighbours the world map gives.
fn mapped(i: usize, ids: &[ClusterId; 3]) -> Vec<ClusterId> {
    match i {
        1 => vec![ids[0], ids[2]],
        _ => vec![ids[1]],
    }
}

fn a_neighbour_never_started_is_never_handed_a_body(ctx: &TestContext) {
    let configs = row(&ctx.url(), mapped);
    let east = configs[2].cluster_id;
    // West and middle run; east is on the map but never started.
    let mut middle = Cluster::new(configs[1].clone()).expect("middle");
    let mut west = Cluster::new(configs[0].clone()).expect("west");
    let ball = ball_at(5.0, middle.id()).velocity([12.0, 0.0, 0.0]);
    middle.spawn_owned(&ball, BodyRole::Dynamic).expect("spawn");
    let refused = middle.transfer_authority(ball.id, east);
    assert!(
        matches!(&refused, Err(ClusterError::Transfer { reason, .. }) if reason.contains("not been heard")),
        "a hand-off to a neighbour never heard from is refused with the reason: {refused:?}"
    );
    // The ball crosses into east's region (x = 10 after 25 ticks) and flies on: the spatial
    // policy would hand it to east, which has never been heard from, so middle keeps it.
    for _ in 0..120 {
        west.tick(|_, _| {}).expect("west ticks");
        middle.tick(|_, _| {}).expect("middle ticks");
    }
    let x = middle
        .sim()
        .state(ball.id)
        .expect("middle has the ball")
        .position[0];
    assert!(x > 20.0, "the ball flew on into east's region: x = {x}");
    assert!(middle.owns(ball.id), "middle still owns the ball");
    let role = middle.sim().info(ball.id).expect("info").role;
    assert_eq!(role, BodyRole::Dynamic, "and simulates it");
    assert_eq!(middle.stats().handoffs_out, 0, "{:?}", middle.stats());
}

fn a_body_is_handed_only_to_a_neighbour_that_models_it(ctx: &TestContext) {
    let mut configs = row(&ctx.url(), mapped);
    for config in &mut configs {
        config.authority = AuthorityMode::Scripted;
        for mapped in &mut config.world {
            mapped.spread = 4.0;
        }
    }
    let mut clusters: Vec<Cluster> = configs
        .iter()
        .map(|c| Cluster::new(c.clone()).expect("cluster"))
        .collect();
    let me = clusters[1].id();
    let (far, near) = (ball_at(0.0, me), ball_at(6.0, me));
    for ball in [&far, &near] {
        clusters[1]
            .spawn_owned(ball, BodyRole::Dynamic)
            .expect("spawn");
    }
    for _ in 0..5 {
        tick_each(&mut clusters.iter_mut().collect::<Vec<_>>());
    }
    let east = clusters[2].id();
    assert!(
        clusters[2].sim().state(near.id).is_some() && clusters[2].sim().state(far.id).is_none(),
        "east models the ball 4 m from its region and not the one 10 m off"
    );
    let refused = clusters[1].transfer_authority(far.id, east);
    assert!(
        matches!(&refused, Err(ClusterError::Transfer { reason, .. }) if reason.contains("does not model it")),
        "a body east does not model is not handed to it: {refused:?}"
    );
    clusters[1]
        .transfer_authority(near.id, east)
        .expect("one east models goes");
    for _ in 0..3 {
        tick_each(&mut clusters.iter_mut().collect::<Vec<_>>());
    }
    assert!(clusters[2].owns(near.id), "east took the ball it modelled");
    assert!(clusters[1].owns(far.id), "middle kept the other");
}

fn a_late_neighbour_gets_the_body_once_it_runs(ctx: &TestContext) {
    let configs = row(&ctx.url(), mapped);
    let mut middle = Cluster::new(configs[1].clone()).expect("middle");
    let mut west = Cluster::new(configs[0].clone()).expect("west");
    let ball = ball_at(5.0, middle.id()).velocity([6.0, 0.0, 0.0]);
    middle.spawn_owned(&ball, BodyRole::Dynamic).expect("spawn");
    // One second without east: the ball is in east's region (x = 11) and still middle's.
    for _ in 0..60 {
        west.tick(|_, _| {}).expect("west ticks");
        middle.tick(|_, _| {}).expect("middle ticks");
    }
    assert!(middle.owns(ball.id));
    // East joins the world's tick count, as a pod on the world's shared schedule does
    // (`Schedule::starting_at`, `Schedule::join`).
    let mut east = Cluster::new(configs[2].clone()).expect("east starts late");
    east.resume_at(middle.sim().tick());
    let mut taken_at = None;
    let mut last_x = middle.sim().state(ball.id).expect("state").position[0];
    for tick in 0..15 {
        tick_each(&mut [&mut west, &mut middle, &mut east]);
        let owners = [&west, &middle, &east].map(|c| c.owns(ball.id));
        assert_eq!(
            owners.iter().filter(|&&o| o).count(),
            1,
            "after tick {tick} the ball has one owner: {owners:?}"
        );
        let owner = if east.owns(ball.id) { &east } else { &middle };
        let x = owner.sim().state(ball.id).expect("state").position[0];
        assert!(
            (x - last_x - 0.1).abs() < 0.05,
            "the ball flies on without a jump at tick {tick}: {last_x} -> {x}"
        );
        last_x = x;
        if owners[2] && taken_at.is_none() {
            taken_at = Some(tick);
        }
        if taken_at.is_some_and(|t| tick > t + 2) {
            break;
        }
    }
    let taken_at = taken_at.expect("east took the ball once it ran");
    assert!(taken_at <= 10, "within a few ticks of starting: {taken_at}");
    assert_eq!(middle.stats().handoffs_out, 1, "{}", middle.stats());
    // Middle's game code pushes the ball, now east's and within middle's sight (its region
    // and spread reach x = 14): the write reaches it there.
    let before = east.sim().state(ball.id).expect("state").linvel[1];
    middle
        .tick(|_, physics| {
            physics
                .apply_impulse(ball.id, [0.0, 50.0, 0.0])
                .expect("routed");
        })
        .expect("middle ticks");
    for _ in 0..6 {
        tick_each(&mut [&mut east, &mut west, &mut middle]);
    }
    let after = east.sim().state(ball.id).expect("state").linvel[1];
    assert!(
        after - before > 0.5,
        "middle's push reached the ball at east: {before} -> {after}"
    );
    assert_eq!(east.stats().ops_applied, 1, "{}", east.stats());
}

fn a_handoff_the_neighbour_does_not_take_comes_back(ctx: &TestContext) {
    // West lists east as its neighbour, east lists nobody: east publishes (so west hears it,
    // alive) but never reads west's frames, so it never takes what west hands it.
    let configs: Vec<ClusterConfig> = row(&ctx.url(), |i, ids| match i {
        0 => vec![ids[2]],
        _ => Vec::new(),
    })
    .into_iter()
    .map(|mut config| {
        config.authority = AuthorityMode::Scripted;
        config
    })
    .collect();
    let timeout = configs[0].neighbour_timeout_ticks;
    let mut west = Cluster::new(configs[0].clone()).expect("west");
    let mut east = Cluster::new(configs[2].clone()).expect("east");
    // West's ball, flown out near east's region (within its spread: east would model it, had
    // it read west's frames).
    let ball = ball_at(8.0, west.id()).velocity([3.0, 0.0, 0.0]);
    west.spawn_owned(&ball, BodyRole::Dynamic).expect("spawn");
    let tick_both = |west: &mut Cluster, east: &mut Cluster| {
        east.tick(|_, _| {}).expect("east ticks");
        west.tick(|_, _| {}).expect("west ticks");
    };
    for _ in 0..5 {
        tick_both(&mut west, &mut east);
    }
    west.transfer_authority(ball.id, east.id())
        .expect("east is heard from, so the hand-off goes");
    tick_both(&mut west, &mut east);
    assert!(!west.owns(ball.id) || west.stats().handoffs_out == 1);
    for _ in 0..timeout + 5 {
        tick_both(&mut west, &mut east);
    }
    let stats = west.stats();
    assert_eq!(stats.handoffs_returned, 1, "{stats:?}");
    assert!(west.owns(ball.id), "the ball came back to west");
    assert!(!east.owns(ball.id), "east never took it");
    let info = west.sim().info(ball.id).expect("info");
    assert_eq!(info.role, BodyRole::Dynamic);
    let before = west.sim().state(ball.id).expect("state").position[0];
    for _ in 0..10 {
        tick_both(&mut west, &mut east);
    }
    let after = west.sim().state(ball.id).expect("state").position[0];
    assert!(
        after - before > 0.4,
        "the ball moves on as west's (3 m/s, 10 ticks): {before} -> {after}"
    );
}

/// Balls spawned by each cluster of the row, flying over both seams and back (they bounce
/// off walls at the row's ends would need scenery; instead they fly at different speeds,
/// some east, some west, so hand-offs happen at many ticks).
fn balls(configs: &[ClusterConfig]) -> Vec<(usize, EntityState)> {
    let mut out = Vec::new();
    for (i, config) in configs.iter().enumerate() {
        let x0 = config.region.min[0] + 2.0;
        for k in 0..6 {
            let speed = 4.0 + 3.0 * k as f32;
            let dir = if k % 2 == 0 { 1.0 } else { -1.0 };
            let ball =
                ball_at(x0 + 3.0 * k as f32, config.cluster_id).velocity([dir * speed, 0.0, 0.0]);
            let ball = EntityState {
                position: [ball.position[0], 3.0 * k as f32, 2.0 * i as f32],
                ..ball
            };
            out.push((i, ball));
        }
    }
    out
}

/// Asserts each ball is owned by exactly one cluster; returns how many changed owner since
/// `last`.
fn one_owner_each(
    clusters: &[Cluster],
    balls: &[(usize, EntityState)],
    last: &mut [usize],
    tick: usize,
) -> usize {
    let mut changed = 0;
    for (b, (_, ball)) in balls.iter().enumerate() {
        let owners: Vec<usize> = (0..clusters.len())
            .filter(|&c| clusters[c].owns(ball.id))
            .collect();
        assert_eq!(
            owners.len(),
            1,
            "after tick {tick}, ball {b} is owned by clusters {owners:?}"
        );
        changed += usize::from(owners[0] != last[b]);
        last[b] = owners[0];
    }
    changed
}

/// The row on the test's transport with [`balls`] spawned by their owners.
fn row_with_balls(ctx: &TestContext) -> (Vec<Cluster>, Vec<(usize, EntityState)>) {
    let configs = row(&ctx.url(), mapped);
    let mut clusters: Vec<Cluster> = configs
        .iter()
        .map(|c| Cluster::new(c.clone()).expect("cluster"))
        .collect();
    let balls = balls(&configs);
    for (i, ball) in &balls {
        clusters[*i]
            .spawn_owned(ball, BodyRole::Dynamic)
            .expect("spawn");
    }
    (clusters, balls)
}

fn every_body_has_one_owner_at_every_tick_in_lockstep(ctx: &TestContext) {
    let (mut clusters, balls) = row_with_balls(ctx);
    let mut last: Vec<usize> = balls.iter().map(|(i, _)| *i).collect();
    let mut handed = 0;
    for tick in 0..240 {
        lockstep_round(
            &mut clusters,
            std::time::Duration::from_secs(10),
            |_, _, _| {},
        )
        .expect("round");
        handed += one_owner_each(&clusters, &balls, &mut last, tick);
    }
    assert!(handed >= 10, "the balls changed owner {handed} times");
}

fn every_body_has_one_owner_at_every_tick_free_running(ctx: &TestContext) {
    let (mut clusters, balls) = row_with_balls(ctx);
    let mut last: Vec<usize> = balls.iter().map(|(i, _)| *i).collect();
    let mut handed = 0;
    for tick in 0..240 {
        // Rounds in turns: each cluster ticks first in some rounds, last in others.
        for k in 0..3 {
            clusters[(tick + k) % 3].tick(|_, _| {}).expect("tick");
        }
        // Through a server a frame takes a moment to arrive; a taker that has not read the
        // frame handing it a body yet counts it as its own only from its next tick (see
        // `ClusterEvent::HandoffTaken::since`; `seam chaos` checks ownership that way).
        if ctx_is_remote(&clusters) {
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        handed += one_owner_each(&clusters, &balls, &mut last, tick);
    }
    assert!(handed >= 10, "the balls changed owner {handed} times");
}

/// One free-running tick of each of `clusters`, in the order given; through a server, then a
/// moment for the frames to arrive.
fn tick_each(clusters: &mut [&mut Cluster]) {
    for cluster in clusters.iter_mut() {
        cluster.tick(|_, _| {}).expect("tick");
    }
    if clusters
        .first()
        .is_some_and(|c| c.config().transport.starts_with("redis"))
    {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// Whether the clusters talk through a server (frames take a little while to arrive).
fn ctx_is_remote(clusters: &[Cluster]) -> bool {
    clusters[0].config().transport.starts_with("redis")
}
