//! Contacts across the seam (see `seam_sim::coupling`): a shot owned by one cluster hits a crate
//! owned by the other, two real Rapier worlds in lock-step on the in-process transport, against
//! one world holding both. With coupling, the crate takes the shot's momentum and the shot
//! meets the crate's mass, in both proxy modes; without it, the crate never moves. Each world
//! sees the contact once, with its impulse and normal, and reads of a proxy give its owner's
//! velocity.

use std::time::Duration;

use seam_proxy::{Cluster, ClusterConfig, ProxyMode, lockstep_round};
use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, Shape};
use seam_sim::{BodyRole, ClusterSim, ContactEvent, LocalOnly, SimConfig};

const TIMEOUT: Duration = Duration::from_secs(10);
const ROUNDS: usize = 30;

fn body(id: EntityId, owner: ClusterId, x: f32, vx: f32, shape: Shape, mass: f32) -> EntityState {
    let volume = match shape {
        Shape::Ball { radius } => 4.0 / 3.0 * std::f32::consts::PI * radius.powi(3),
        Shape::Cuboid {
            half_extents: [a, b, c],
        } => 8.0 * a * b * c,
        Shape::Capsule { .. } | Shape::Catalog { .. } => unreachable!("not used here"),
    };
    let body = BodySpec::new(shape).density(mass / volume).ccd(true);
    EntityState::new(id, owner, body)
        .at([x, 0.0, 0.0])
        .velocity([vx, 0.0, 0.0])
}

/// A 1 kg ball at 200 m/s (CCD) fired at a 100 kg crate 20 m away, no gravity.
struct Shot {
    ball: EntityId,
    crate_: EntityId,
}

impl Shot {
    fn new() -> Self {
        Self {
            ball: EntityId::random(),
            crate_: EntityId::random(),
        }
    }

    fn ball(&self, owner: ClusterId) -> EntityState {
        let shape = Shape::Ball { radius: 0.1 };
        body(self.ball, owner, -20.0, 200.0, shape, 1.0)
    }

    fn crate_(&self, owner: ClusterId) -> EntityState {
        let shape = Shape::Cuboid {
            half_extents: [0.5; 3],
        };
        body(self.crate_, owner, 0.5, 0.0, shape, 100.0)
    }

    /// The ball's and the crate's x velocity after `ROUNDS` ticks of one world holding both.
    fn one_world(&self) -> (f32, f32) {
        let here = ClusterId::random();
        let mut sim = ClusterSim::new(SimConfig {
            gravity: [0.0; 3],
            ..SimConfig::new(here)
        });
        sim.spawn(&self.ball(here), BodyRole::Dynamic)
            .expect("ball");
        sim.spawn(&self.crate_(here), BodyRole::Dynamic)
            .expect("crate");
        for _ in 0..ROUNDS {
            sim.run_user(&mut LocalOnly, |_, _| ());
            sim.step();
        }
        let v = |id| sim.state(id).expect("there").linvel[0];
        (v(self.ball), v(self.crate_))
    }
}

/// What one split run saw.
struct Split {
    /// The ball's x velocity at its owner (west), the crate's at its owner (east).
    ball_v: f32,
    crate_v: f32,
    /// Contacts between the two, per cluster (west, east), as user code saw them.
    contacts: [Vec<ContactEvent>; 2],
    /// The crate's x velocity read from west's proxy of it, and the ball's from east's, in
    /// the last round.
    crate_read_in_west: f32,
    ball_read_in_east_first: Option<f32>,
    coupled: u64,
}

/// West, owning the ball, and east, owning the crate, without gravity.
fn west_and_east(shot: &Shot, mode: ProxyMode, coupling: bool, test: &str) -> Vec<Cluster> {
    pair(|w| shot.ball(w), |e| shot.crate_(e), mode, coupling, test)
}

/// West, owning the body `west_owns` makes, and east, owning `east_owns`'s, without gravity.
fn pair(
    west_owns: impl Fn(ClusterId) -> EntityState,
    east_owns: impl Fn(ClusterId) -> EntityState,
    mode: ProxyMode,
    coupling: bool,
    test: &str,
) -> Vec<Cluster> {
    let (west, east) = (ClusterId::random(), ClusterId::random());
    let url = format!("local?prefix=seam_{test}_{}_", std::process::id());
    let mut clusters: Vec<Cluster> = [(west, east), (east, west)]
        .into_iter()
        .map(|(me, other)| {
            let mut config = ClusterConfig::new(me, vec![other], &url);
            config.gravity = [0.0; 3];
            config.proxy_mode = mode;
            config.coupling = coupling;
            Cluster::new(config).expect("cluster")
        })
        .collect();
    clusters[0]
        .spawn_owned(&west_owns(west), BodyRole::Dynamic)
        .expect("west's body");
    clusters[1]
        .spawn_owned(&east_owns(east), BodyRole::Dynamic)
        .expect("east's body");
    clusters
}

fn split(shot: &Shot, mode: ProxyMode, coupling: bool, test: &str) -> Split {
    let mut clusters = west_and_east(shot, mode, coupling, test);
    let mut contacts: [Vec<ContactEvent>; 2] = [Vec::new(), Vec::new()];
    let mut crate_read_in_west = f32::NAN;
    let mut ball_read_in_east_first = None;
    for _ in 0..ROUNDS {
        lockstep_round(&mut clusters, TIMEOUT, |index, context, physics| {
            contacts[index].extend(context.contacts().iter().filter(|c| {
                [c.a, c.b] == [shot.ball, shot.crate_] || [c.a, c.b] == [shot.crate_, shot.ball]
            }));
            if index == 0 && context.entity(shot.crate_).is_some() {
                crate_read_in_west = physics.linvel(shot.crate_).expect("proxy")[0];
            }
            if index == 1
                && ball_read_in_east_first.is_none()
                && context.entity(shot.ball).is_some()
            {
                ball_read_in_east_first = Some(physics.linvel(shot.ball).expect("proxy")[0]);
            }
        })
        .expect("round");
    }
    let v = |cluster: &Cluster, id| cluster.sim().state(id).expect("there").linvel[0];
    Split {
        ball_v: v(&clusters[0], shot.ball),
        crate_v: v(&clusters[1], shot.crate_),
        contacts,
        crate_read_in_west,
        ball_read_in_east_first,
        coupled: clusters.iter().map(|c| c.stats().proxies_coupled).sum(),
    }
}

fn within(value: f32, truth: f32, share: f32) -> bool {
    (value - truth).abs() <= share * truth.abs()
}

/// The crate takes the shot's momentum as in one world (within 10 %), and the shot meets the
/// crate's mass rather than a wall: in both proxy modes.
#[test]
fn a_shot_moves_the_heavy_crate_it_hits_across_the_seam_as_in_one_world() {
    let shot = Shot::new();
    let (ball_truth, crate_truth) = shot.one_world();
    assert!(
        crate_truth > 1.5,
        "one world gives the crate about 2 m/s: {crate_truth}"
    );
    for mode in [ProxyMode::Fixed, ProxyMode::KinematicVelocityBased] {
        let run = split(&shot, mode, true, "shot");
        assert!(run.coupled > 0, "{mode:?}: proxies were coupled");
        assert!(
            within(run.crate_v, crate_truth, 0.10),
            "{mode:?}: crate {} m/s, one world {crate_truth} m/s",
            run.crate_v
        );
        assert!(
            within(run.ball_v, ball_truth, 0.10),
            "{mode:?}: ball {} m/s after the hit, one world {ball_truth} m/s",
            run.ball_v
        );
    }
}

/// The other side of the boundary: with coupling off the crate never moves (a Fixed proxy of
/// the crate stops the shot dead, and the crate's owner only ever meets a proxy of the ball).
#[test]
fn without_coupling_the_crate_never_moves() {
    let shot = Shot::new();
    let run = split(&shot, ProxyMode::Fixed, false, "nocoupling");
    assert_eq!(run.coupled, 0);
    assert!(
        run.crate_v.abs() < 0.05,
        "the crate stays put without coupling: {} m/s",
        run.crate_v
    );
}

/// Each world sees the contact once — its own event, not also its neighbour's report of the
/// same pair — with the impulse the crate took (its momentum change, ±10 %) and a normal along
/// the shot.
#[test]
fn each_world_sees_the_contact_once_with_impulse_and_normal() {
    let shot = Shot::new();
    let (_, crate_truth) = shot.one_world();
    let run = split(&shot, ProxyMode::Fixed, true, "once");
    for (side, seen) in ["west", "east"].iter().zip(&run.contacts) {
        let started: Vec<&ContactEvent> = seen.iter().filter(|c| c.started).collect();
        assert_eq!(started.len(), 1, "{side} sees the hit start once: {seen:?}");
        let hit = started[0];
        assert_eq!(hit.reported_by, None, "{side} saw it in its own world");
        // The impulse on `b`, whichever of the two `b` is.
        let on_crate = if hit.b == shot.crate_ {
            hit.impulse[0]
        } else {
            -hit.impulse[0]
        };
        assert!(
            within(on_crate, 100.0 * crate_truth, 0.10),
            "{side}: impulse on the crate {on_crate} N·s, one world's momentum change {}",
            100.0 * crate_truth
        );
        let along = if hit.b == shot.crate_ {
            hit.normal[0]
        } else {
            -hit.normal[0]
        };
        assert!(along > 0.9, "{side}: normal from ball to crate: {hit:?}");
    }
}

/// Reads of a proxy give its owner's velocity: the ball's proxy in east reads 200 m/s (a Fixed
/// body has none of its own, a kinematic one its dead-reckoning velocity), and west's proxy of
/// the crate reads the crate's velocity after the hit.
#[test]
fn reads_of_a_proxy_give_the_replicated_velocity() {
    let shot = Shot::new();
    for mode in [ProxyMode::Fixed, ProxyMode::KinematicVelocityBased] {
        let run = split(&shot, mode, true, "reads");
        let ball = run.ball_read_in_east_first.expect("east models the ball");
        assert!(
            (ball - 200.0).abs() < 1e-3,
            "{mode:?}: east reads the ball at {ball} m/s"
        );
        assert!(
            within(run.crate_read_in_west, run.crate_v, 0.05),
            "{mode:?}: west reads the crate at {} m/s, its owner has {} m/s",
            run.crate_read_in_west,
            run.crate_v
        );
    }
}

/// A contact only one world reported is passed to the other body's owner as a push only once
/// that owner has published its reports of the step: the crate's owner stalls after two
/// rounds, the shot hits west's proxy of the crate, and west waits for east's reports of that
/// step, which never come. Routing the push anyway would send it to a pod that could not take
/// it (in `seam chaos`, most such pushes were lost with a stopped or killed pod); west counts
/// the half as unjudged instead.
#[test]
fn a_stalled_owner_is_sent_no_push_for_a_contact_it_could_not_report() {
    let shot = Shot::new();
    let mut clusters = west_and_east(&shot, ProxyMode::Fixed, true, "stalled");
    for _ in 0..2 {
        lockstep_round(&mut clusters, TIMEOUT, |_, _, _| ()).expect("round");
    }
    let west_cluster = &mut clusters[0];
    // East is silent from here on; well within its 60-tick timeout, so still taken as alive.
    for _ in 0..12 {
        west_cluster.tick(|_, _| ()).expect("west ticks alone");
    }
    let stats = west_cluster.stats();
    assert!(
        stats.seam_impulses_sent > 0,
        "the shot met the crate's proxy in west: {stats:?}"
    );
    assert_eq!(stats.seam_impulses_routed, 0, "{stats:?}");
    assert!(stats.seam_impulses_unjudged > 0, "{stats:?}");
}

/// A blast that west's game code writes on its own crate and on east's crate beside it (2 cm
/// apart across the seam) pushes both the same way, 5 m/s: in one world they move off
/// together and never touch. The push on east's crate reaches east a tick later; west shows it
/// on its coupled proxy of the crate in the step it was written, so west's crate does not ram
/// a proxy still standing and keeps its 5 m/s (without that it shares them with the proxy:
/// about 2.5 m/s).
#[test]
fn a_push_routed_across_the_seam_moves_the_proxy_in_the_step_it_is_written() {
    let (mine, theirs) = (EntityId::random(), EntityId::random());
    let cube = Shape::Cuboid {
        half_extents: [0.5; 3],
    };
    let mut clusters = pair(
        |w| body(mine, w, -0.51, 0.0, cube, 100.0),
        |e| body(theirs, e, 0.51, 0.0, cube, 100.0),
        ProxyMode::Fixed,
        true,
        "predicted",
    );
    const BLAST_ROUND: usize = 3;
    let mut after = f32::NAN;
    for round in 0..=BLAST_ROUND + 1 {
        lockstep_round(&mut clusters, TIMEOUT, |index, _, physics| {
            if index != 0 {
                return;
            }
            if round == BLAST_ROUND {
                for crate_ in [mine, theirs] {
                    physics
                        .apply_impulse(crate_, [500.0, 0.0, 0.0])
                        .expect("a write on either crate");
                }
            }
            if round == BLAST_ROUND + 1 {
                after = physics.linvel(mine).expect("west's crate")[0];
            }
        })
        .expect("round");
    }
    assert!(
        within(after, 5.0, 0.10),
        "west's crate after the blast: {after} m/s, one world 5 m/s"
    );
    let stats = clusters[0].stats();
    assert!(stats.impulses_predicted > 0, "{stats:?}");
}

/// Scenery floor, 20 m square, its top at y = 0, for cluster `me`.
fn floor(me: ClusterId) -> EntityState {
    let slab = Shape::Cuboid {
        half_extents: [10.0, 0.5, 10.0],
    };
    EntityState::new(EntityId::random(), me, BodySpec::new(slab)).at([0.0, -0.5, 0.0])
}

/// A cluster of `config` with the floor loaded.
fn on_floor(config: ClusterConfig) -> Cluster {
    let me = config.cluster_id;
    let mut cluster = Cluster::new(config).expect("cluster");
    cluster.spawn_scenery(&floor(me)).expect("floor");
    cluster
}

/// A 1 m crate of 20 kg owned by `owner`, its centre at `position`.
fn crate_at(id: EntityId, owner: ClusterId, position: [f32; 3]) -> EntityState {
    let cube = Shape::Cuboid {
        half_extents: [0.5; 3],
    };
    EntityState::new(id, owner, BodySpec::new(cube).density(20.0)).at(position)
}

/// After its first step `east` holds west's crate `lower` and its own crate `upper` stood on
/// it (a crate falling freely through a step is at −0.16 m/s).
fn assert_stood_from_the_first_step(east: &Cluster, lower: EntityId, upper: EntityId) {
    assert!(
        east.sim().contains(lower),
        "east holds west's crate after its first step"
    );
    let upper_v = east.sim().state(upper).expect("east's crate").linvel[1];
    assert!(
        upper_v > -0.05,
        "the crate stood on its neighbour's in the first step: {upper_v} m/s"
    );
}

/// Lock-step, each world holds its neighbours' proxies from its first step (their frames of
/// tick 0 come in before it): a crate standing on a neighbour's crate is held up in that step
/// as in one world. Before, the proxy came a tick late and the crate fell freely through the
/// first step (0.16 m/s, 1.6 mm at 60 Hz); two crates of two clusters stacked on a third fell
/// alike and ended exactly touching, which Rapier's contact between convex hulls can miss for
/// ticks (7 cm through, docs/accuracy.md).
#[test]
fn a_crate_on_a_neighbours_crate_stands_from_the_first_step() {
    let (west, east) = (ClusterId::random(), ClusterId::random());
    let url = format!("local?prefix=seam_first_step_{}_", std::process::id());
    let (lower, upper) = (EntityId::random(), EntityId::random());
    let mut clusters: Vec<Cluster> = [(west, east), (east, west)]
        .into_iter()
        .map(|(me, other)| on_floor(ClusterConfig::new(me, vec![other], &url)))
        .collect();
    clusters[0]
        .spawn_owned(&crate_at(lower, west, [0.0, 0.5, 0.0]), BodyRole::Dynamic)
        .expect("west's crate");
    clusters[1]
        .spawn_owned(&crate_at(upper, east, [0.0, 1.5, 0.0]), BodyRole::Dynamic)
        .expect("east's crate on it");
    lockstep_round(&mut clusters, TIMEOUT, |_, _, _| ()).expect("first tick");
    assert_stood_from_the_first_step(&clusters[1], lower, upper);
}

/// A body at rest beside a neighbour's body that moves without touching it falls asleep when
/// one world's does. Rapier strongly wakes every body near a collider moved from outside a
/// step, so a coupled proxy set to each frame of a ball spinning in place kept the crate
/// beside it awake for good; one world lets the crate sleep half a second after it rests. A
/// struck stack answers the strike differently asleep and awake (`open/four-corners`: 3.3 mm
/// RMS against a floor of 0.7 mm, now 0.4 mm), so the split's stack must sleep when one
/// world's does.
#[test]
fn a_crate_beside_a_neighbours_spinning_ball_falls_asleep_as_in_one_world() {
    let (west, east) = (ClusterId::random(), ClusterId::random());
    let url = format!("local?prefix=seam_asleep_beside_{}_", std::process::id());
    let (crate_id, ball) = (EntityId::random(), EntityId::random());
    // Diagonal off the crate's vertical edge: their boxes overlap (a pair in Rapier's contact
    // graph), their shapes stay 4.7 cm apart (within the coupling's reach).
    let crate_state = crate_at(crate_id, west, [0.0, 0.5, 0.0]);
    let ball_state = EntityState::new(ball, east, BodySpec::new(Shape::ball(0.25)))
        .at([0.71, 0.25, 0.71])
        .spin([0.0, 3.0, 0.0]);
    let new_cluster = |me, neighbours| on_floor(ClusterConfig::new(me, neighbours, &url));
    // One world: the crate sleeps once it has rested half a second.
    let mut one = new_cluster(ClusterId::random(), vec![]);
    for state in [crate_state, ball_state] {
        let state = EntityState {
            cluster_id: one.id(),
            ..state
        };
        one.spawn_owned(&state, BodyRole::Dynamic)
            .expect("one world");
    }
    let mut clusters = vec![new_cluster(west, vec![east]), new_cluster(east, vec![west])];
    clusters[0]
        .spawn_owned(&crate_state, BodyRole::Dynamic)
        .expect("west's crate");
    clusters[1]
        .spawn_owned(&ball_state, BodyRole::Dynamic)
        .expect("east's ball");
    for _ in 0..90 {
        lockstep_round(std::slice::from_mut(&mut one), TIMEOUT, |_, _, _| ()).expect("one");
        lockstep_round(&mut clusters, TIMEOUT, |_, _, _| ()).expect("split");
    }
    assert_eq!(
        one.sim().is_asleep(crate_id),
        Some(true),
        "one world's crate"
    );
    assert_eq!(one.sim().is_asleep(ball), Some(false), "the ball spins on");
    assert!(clusters[0].sim().contains(ball), "west holds east's ball");
    assert_eq!(
        clusters[0].sim().is_asleep(crate_id),
        Some(true),
        "west's crate sleeps as one world's does"
    );
}

/// Free-running too: a pod sends its frames of tick 0 before its first step and waits (at most
/// `neighbour_wait_ticks`) for its neighbours', so a crate resting on a neighbour's stands
/// from the first step. West begins 50 ms after east (the wait is a second here, so a busy
/// machine does not make it run out): before, east stepped at once without west's crate and
/// its own fell freely through the step.
///
/// West stays up until east has been judged, as a running pod does. A pod that dropped its
/// transport right after its tick took its frames with it: an iceoryx2 subscriber maps a new
/// publisher's samples only when it next looks, so samples of a publisher gone before then
/// never arrive (CI, stop 59: east waited its whole second and heard nothing in about half
/// the runs here).
#[test]
fn a_free_running_crate_on_a_neighbours_crate_stands_from_the_first_step() {
    let (west, east) = (ClusterId::random(), ClusterId::random());
    let url = format!("local?prefix=seam_first_free_{}_", std::process::id());
    let (lower, upper) = (EntityId::random(), EntityId::random());
    let both = std::sync::Barrier::new(2);
    // Dropped once east is judged (or its thread panics): west's pod goes down then.
    let (judged_tx, judged_rx) = std::sync::mpsc::channel::<()>();
    let pod = |me, other, id, y: f32, late: bool| {
        let mut config = ClusterConfig::new(me, vec![other], &url);
        config.neighbour_wait_ticks = 60.0;
        let mut cluster = on_floor(config);
        cluster
            .spawn_owned(&crate_at(id, me, [0.0, y, 0.0]), BodyRole::Dynamic)
            .expect("crate");
        both.wait();
        if late {
            std::thread::sleep(Duration::from_millis(50));
        }
        cluster.tick(|_, _| ()).expect("first tick");
        cluster
    };
    // A cluster stays on its thread: east is judged there.
    let pod = &pod;
    std::thread::scope(|s| {
        s.spawn(move || {
            let _west = pod(west, east, lower, 0.5, true);
            let _ = judged_rx.recv_timeout(Duration::from_secs(30));
        });
        let judged = s.spawn(move || {
            let _judged = judged_tx;
            assert_stood_from_the_first_step(&pod(east, west, upper, 1.5, false), lower, upper)
        });
        judged
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
    });
}
