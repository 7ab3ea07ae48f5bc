//! No entity lost: the entities of a cluster taken for dead are adopted by exactly one
//! survivor, by the rule every survivor computes the same way (nearest region, then smallest
//! id); an entity handed to it just before it died comes back to the cluster that handed it;
//! and when it is heard from again, the adopters hand them back. A cluster that says it is
//! leaving is not taken for dead: nothing is adopted from it. Three clusters
//! in a row along x, in one process on the in-process transport.

use seam_proxy::{AuthorityMode, Cluster, NeighbourStatus};
use seam_sim::BodyRole;
use seam_sim::wire::{EntityId, EntityState};
use seam_tests::{HandClock, ball_at, row_configs};

const TIMEOUT_TICKS: u64 = 10;

/// West [-30,-10], middle [-10,10], east [10,30]; middle neighbours both, they only it.
fn row(url: &str) -> [Cluster; 3] {
    let configs = row_configs(url, &[(-30.0, -10.0), (-10.0, 10.0), (10.0, 30.0)]);
    [0, 1, 2].map(|i| {
        let mut config = configs[i].clone();
        config.spread = 40.0;
        config.neighbour_timeout_ticks = TIMEOUT_TICKS;
        // Authority moves by the test's hand-off and by adoption only: the ball west hands
        // to middle lies in west's region, where a spatial policy would hand it straight back.
        config.authority = AuthorityMode::Scripted;
        Cluster::new(config).expect("cluster")
    })
}

/// One tick of each of `which`, one `dt` of host time after the last (a neighbour is taken
/// for dead after the timeout in ticks and in host time).
fn tick(clusters: &mut [Cluster], clock: &mut HandClock, which: &[usize]) {
    let now = clock.advance();
    for &i in which {
        clusters[i].tick_at(now, |_, _| {}).expect("tick");
    }
}

struct Setup {
    clusters: [Cluster; 3],
    clock: HandClock,
    /// Middle's, at x = -4, 0 and 4.
    balls: Vec<EntityState>,
    /// West's, at x = -12, for west to hand to middle.
    handed: EntityState,
}

/// The row, its balls spawned and three ticks run.
fn setup(test: &str) -> Setup {
    let url = format!("local?prefix=seam_{test}_{}_", std::process::id());
    let mut clusters = row(&url);
    let mut clock = HandClock::new(clusters[0].config().dt);
    let (west, middle, east) = (0, 1, 2);
    let middle_id = clusters[middle].id();
    let balls: Vec<_> = [-4.0, 0.0, 4.0]
        .iter()
        .map(|&x| ball_at(x, middle_id))
        .collect();
    for ball in &balls {
        clusters[middle]
            .spawn_owned(ball, BodyRole::Dynamic)
            .expect("spawn");
    }
    let handed = ball_at(-12.0, clusters[west].id());
    clusters[west]
        .spawn_owned(&handed, BodyRole::Dynamic)
        .expect("spawn");
    for _ in 0..3 {
        tick(&mut clusters, &mut clock, &[west, middle, east]);
    }
    Setup {
        clusters,
        clock,
        balls,
        handed,
    }
}

/// Which of `among` own `id` (as a simulated body).
fn owners_among(clusters: &[Cluster], among: &[usize], id: EntityId) -> Vec<usize> {
    among
        .iter()
        .copied()
        .filter(|&i| {
            clusters[i].sim().info(id).is_some_and(|info| {
                info.owner == clusters[i].id() && info.role == BodyRole::Dynamic
            })
        })
        .collect()
}

/// Which clusters own `id`.
fn owners(clusters: &[Cluster], id: EntityId) -> Vec<usize> {
    owners_among(clusters, &[0, 1, 2], id)
}

#[test]
fn a_dead_clusters_entities_are_adopted_once_and_returned() {
    let Setup {
        mut clusters,
        mut clock,
        balls,
        handed,
    } = setup("adopt");
    let (west, middle, east) = (0, 1, 2);
    // West hands a ball to middle, which dies before it reads the hand-off.
    let middle_id = clusters[middle].id();
    clusters[west]
        .transfer_authority(handed.id, middle_id)
        .expect("hand-off");
    tick(&mut clusters, &mut clock, &[west, east]);
    let survivors = |clusters: &[Cluster], id| owners_among(clusters, &[0, 2], id);
    assert_eq!(
        survivors(&clusters, handed.id),
        Vec::<usize>::new(),
        "in flight"
    );
    for _ in 0..TIMEOUT_TICKS + 1 {
        tick(&mut clusters, &mut clock, &[west, east]);
    }
    for survivor in [west, east] {
        assert_eq!(
            clusters[survivor].neighbour_status(middle_id),
            Some(NeighbourStatus::Dead)
        );
    }
    // Nearest region adopts; the ball at 0 is as near to both, so the smaller id takes it.
    let tie = if clusters[west].id() < clusters[east].id() {
        west
    } else {
        east
    };
    assert_eq!(survivors(&clusters, balls[0].id), vec![west], "ball at -4");
    assert_eq!(survivors(&clusters, balls[1].id), vec![tie], "ball at 0");
    assert_eq!(survivors(&clusters, balls[2].id), vec![east], "ball at +4");
    assert_eq!(
        survivors(&clusters, handed.id),
        vec![west],
        "the hand-off middle never took is back with west"
    );
    let adopted: u64 = clusters.iter().map(|c| c.stats().entities_adopted).sum();
    assert_eq!(adopted, 3, "each of middle's balls adopted once");
    assert_eq!(clusters[west].stats().handoffs_reclaimed, 1);
    // Neither survivor keeps a proxy of middle.
    for survivor in [west, east] {
        let of_middle = clusters[survivor]
            .sim()
            .entities()
            .filter(|(_, info)| info.owner == middle_id)
            .count();
        assert_eq!(of_middle, 0, "no proxy of the dead cluster left");
    }

    // Middle was only stalled: it returns, still claiming its balls. Hearing it again, the
    // adopters hand back what they adopted from it, and west completes the hand-off it took
    // back; afterwards each ball has one owner, middle.
    for _ in 0..4 {
        tick(&mut clusters, &mut clock, &[west, middle, east]);
    }
    for ball in balls.iter().chain([&handed]) {
        assert_eq!(owners(&clusters, ball.id), vec![middle], "{}", ball.id);
    }
    let returned: u64 = clusters.iter().map(|c| c.stats().entities_returned).sum();
    assert_eq!(
        returned, 4,
        "three adopted balls and the reclaimed one went back"
    );
    for survivor in [west, east] {
        assert_eq!(
            clusters[survivor].neighbour_status(middle_id),
            Some(NeighbourStatus::Alive)
        );
    }
}

#[test]
fn a_cluster_that_leaves_is_not_taken_for_dead_and_keeps_what_it_owns() {
    let Setup {
        mut clusters,
        mut clock,
        balls,
        handed,
    } = setup("leave");
    let (west, middle, east) = (0, 1, 2);
    let middle_id = clusters[middle].id();
    // West hands a ball to middle, which stops on purpose before it reads the hand-off, and
    // says so; west and east go on far past the timeout.
    clusters[west]
        .transfer_authority(handed.id, middle_id)
        .expect("hand-off");
    tick(&mut clusters, &mut clock, &[west, east]);
    clusters[middle].leave().expect("leave");
    for _ in 0..3 * TIMEOUT_TICKS {
        tick(&mut clusters, &mut clock, &[west, east]);
    }
    for survivor in [west, east] {
        assert_eq!(
            clusters[survivor].neighbour_status(middle_id),
            Some(NeighbourStatus::Left)
        );
        let stats = clusters[survivor].stats();
        assert_eq!((stats.neighbours_lost, stats.neighbours_left), (0, 1));
        assert_eq!(
            stats.entities_adopted, 0,
            "nothing adopted from a cluster that left"
        );
    }
    for ball in &balls {
        assert_eq!(
            owners(&clusters, ball.id),
            vec![middle],
            "middle keeps {}",
            ball.id
        );
    }
    assert_eq!(
        owners(&clusters, handed.id),
        vec![west],
        "the hand-off middle never took is back with west"
    );
    assert_eq!(clusters[west].stats().handoffs_taken_back, 1);
    assert!(
        clusters[west]
            .transfer_authority(handed.id, middle_id)
            .is_err(),
        "nothing is handed to a cluster that left"
    );
}
