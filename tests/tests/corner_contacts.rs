//! Contacts at a corner where four clusters meet (issue 36 item 3): a block of four crates
//! touching each other round the corner point, each owned by the cluster of its quadrant, and
//! a shot of a fifth body's cluster ramming one of them. Every contact of the block is seen by
//! several clusters at once (each couples its neighbours' crates that its own one touches), so
//! a contact applied by more than one side would push a crate harder than one world does. Four
//! real Rapier worlds in lock-step on the in-process transport, against one world holding all.

use std::collections::HashMap;
use std::time::Duration;

use seam_proxy::{Cluster, ClusterConfig, Region, lockstep_round};
use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, Shape};
use seam_sim::{BodyRole, ClusterSim, LocalOnly, SimConfig};

const TIMEOUT: Duration = Duration::from_secs(10);
const ROUNDS: usize = 30;
const SPREAD: f32 = 5.0;
const HALF: f32 = 0.5;
/// A crate is a metre cube of this density, so this heavy.
const CRATE_KG: f32 = 100.0;
const BALL_KG: f32 = 2.0;

/// The four quadrants round (0, 0), as (name, x sign, y sign).
const QUADRANTS: [(&str, f32, f32); 4] = [
    ("north-east", 1.0, 1.0),
    ("north-west", -1.0, 1.0),
    ("south-west", -1.0, -1.0),
    ("south-east", 1.0, -1.0),
];

/// A crate of each quadrant, centred half a crate from both seams, so that the four touch
/// (1 mm apart) and meet at the corner point; and a 2 kg ball fired at 200 m/s along `aim`
/// from 20 m out, owned by the quadrant it starts in.
struct Corner {
    crates: [EntityId; 4],
    ball: EntityId,
    ball_from: [f32; 3],
    ball_velocity: [f32; 3],
}

impl Corner {
    fn new(ball_from: [f32; 3], towards: [f32; 3]) -> Self {
        let d: Vec<f32> = (0..3).map(|i| towards[i] - ball_from[i]).collect();
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        Self {
            crates: std::array::from_fn(|_| EntityId::random()),
            ball: EntityId::random(),
            ball_from,
            ball_velocity: [200.0 * d[0] / len, 200.0 * d[1] / len, 200.0 * d[2] / len],
        }
    }

    /// The index of the quadrant `point` lies in.
    fn quadrant_of(point: [f32; 3]) -> usize {
        QUADRANTS
            .iter()
            .position(|&(_, sx, sy)| point[0] * sx >= 0.0 && point[1] * sy >= 0.0)
            .expect("every point is in a quadrant")
    }

    fn crate_(&self, quadrant: usize, owner: ClusterId) -> EntityState {
        let (_, sx, sy) = QUADRANTS[quadrant];
        let c = HALF + 0.0005;
        let spec = BodySpec::new(Shape::cuboid(HALF, HALF, HALF)).density(CRATE_KG);
        EntityState::new(self.crates[quadrant], owner, spec).at([sx * c, sy * c, 0.0])
    }

    fn ball(&self, owner: ClusterId) -> EntityState {
        let volume = 4.0 / 3.0 * std::f32::consts::PI * 0.1f32.powi(3);
        let spec = BodySpec::new(Shape::ball(0.1))
            .density(BALL_KG / volume)
            .ccd(true);
        EntityState::new(self.ball, owner, spec)
            .at(self.ball_from)
            .velocity(self.ball_velocity)
    }

    fn bodies(&self) -> Vec<EntityId> {
        let mut all = self.crates.to_vec();
        all.push(self.ball);
        all
    }

    /// Every body's linear velocity after `ROUNDS` ticks of one world holding them all,
    /// inserted in `order` (indices into [`Corner::bodies`]).
    fn one_world(&self, order: &[usize]) -> HashMap<EntityId, [f32; 3]> {
        let here = ClusterId::random();
        let mut sim = ClusterSim::new(SimConfig {
            gravity: [0.0; 3],
            ..SimConfig::new(here)
        });
        for &i in order {
            let body = if i < 4 {
                self.crate_(i, here)
            } else {
                self.ball(here)
            };
            sim.spawn(&body, BodyRole::Dynamic).expect("body");
        }
        for _ in 0..ROUNDS {
            sim.run_user(&mut LocalOnly, |_, _| ());
            sim.step();
        }
        self.bodies()
            .into_iter()
            .map(|id| (id, sim.state(id).expect("there").linvel))
            .collect()
    }

    /// Every body's linear velocity at its owner after `ROUNDS` lock-step ticks of the four
    /// clusters, and how many proxies the clusters coupled.
    fn split(&self, test: &str) -> (HashMap<EntityId, [f32; 3]>, u64) {
        let url = format!("local?prefix=seam_{test}_{}_", std::process::id());
        let ids: Vec<ClusterId> = QUADRANTS.iter().map(|_| ClusterId::random()).collect();
        let world: Vec<(ClusterId, Region, f32)> = QUADRANTS
            .iter()
            .zip(&ids)
            .map(|(&(_, sx, sy), &id)| {
                let (x, y) = ([0.0, 100.0 * sx], [0.0, 100.0 * sy]);
                let region = Region {
                    min: [x[0].min(x[1]), y[0].min(y[1]), -100.0],
                    max: [x[0].max(x[1]), y[0].max(y[1]), 100.0],
                };
                (id, region, SPREAD)
            })
            .collect();
        let mut clusters: Vec<Cluster> = ids
            .iter()
            .map(|&id| {
                let mut config = ClusterConfig::in_world(id, &world, &url).expect("world");
                config.gravity = [0.0; 3];
                Cluster::new(config).expect("cluster")
            })
            .collect();
        for (q, cluster) in clusters.iter_mut().enumerate() {
            let mine = self.crate_(q, ids[q]);
            cluster
                .spawn_owned(&mine, BodyRole::Dynamic)
                .expect("crate");
        }
        let shooter = Self::quadrant_of(self.ball_from);
        clusters[shooter]
            .spawn_owned(&self.ball(ids[shooter]), BodyRole::Dynamic)
            .expect("ball");
        for _ in 0..ROUNDS {
            lockstep_round(&mut clusters, TIMEOUT, |_, _, _| ()).expect("round");
        }
        let coupled = clusters.iter().map(|c| c.stats().proxies_coupled).sum();
        let velocities = self
            .bodies()
            .into_iter()
            .map(|id| {
                let owners: Vec<&Cluster> = clusters.iter().filter(|c| c.owns(id)).collect();
                assert_eq!(owners.len(), 1, "{test}: {id} owned by one cluster");
                (id, owners[0].sim().state(id).expect("there").linvel)
            })
            .collect();
        (velocities, coupled)
    }
}

/// Every order of `n` indices.
fn orders(n: usize) -> Vec<Vec<usize>> {
    if n == 0 {
        return vec![Vec::new()];
    }
    let mut all = Vec::new();
    for shorter in orders(n - 1) {
        for at in 0..=shorter.len() {
            let mut order = shorter.clone();
            order.insert(at, n - 1);
            all.push(order);
        }
    }
    all
}

fn norm(v: [f32; 3]) -> f32 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn minus(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn momentum(corner: &Corner, velocities: &HashMap<EntityId, [f32; 3]>) -> [f32; 3] {
    let mut total = [0.0; 3];
    for (i, id) in corner.bodies().iter().enumerate() {
        let mass = if i < 4 { CRATE_KG } else { BALL_KG };
        for (t, v) in total.iter_mut().zip(velocities[id]) {
            *t += mass * v;
        }
    }
    total
}

/// Each body's velocity (from rest, for the crates) against one world's, within the noise
/// floor: how far one world with the same bodies inserted in another order ends from it.
///
/// Rapier's solver runs a fixed number of iterations over the contacts in the order its
/// bodies were inserted, and a block of four crates hit at a corner is far from converged:
/// one world inserting the south-west crate and the ball first ends with that crate 0.46 m/s
/// from the one inserting them in quadrant order (0.75, −0.83 against 0.68, −0.37 m/s),
/// where inserting them in reverse order changes nothing (1e-6 m/s). Every split world
/// inserts its bodies in an order of its own, so no split can be nearer one world than that.
/// The floor is the largest such distance over every order of the five bodies; a body is held
/// within 1.5 times it, or 10 % of the largest crate's velocity where the floor is smaller. A
/// contact applied by two sides would double a crate's velocity.
fn assert_as_in_one_world(corner: &Corner, test: &str) {
    let all = orders(5);
    let truth = corner.one_world(&all[0]);
    let mut floor: HashMap<EntityId, f32> = HashMap::new();
    for order in &all[1..] {
        let other = corner.one_world(order);
        for id in corner.bodies() {
            let off = norm(minus(other[&id], truth[&id]));
            let worst = floor.entry(id).or_default();
            *worst = worst.max(off);
        }
    }
    let (split, coupled) = corner.split(test);
    assert!(coupled > 0, "{test}: the clusters coupled proxies");
    let largest = corner
        .crates
        .iter()
        .map(|id| norm(truth[id]))
        .fold(0.0, f32::max);
    assert!(
        largest > 0.5,
        "{test}: one world moves the crates: {truth:?}"
    );
    let (p_one, p_split) = (momentum(corner, &truth), momentum(corner, &split));
    let p_ball = BALL_KG * norm(corner.ball_velocity);
    let p_off = norm(minus(p_split, p_one)) / p_ball;
    println!(
        "{test}: momentum {p_split:?} kg m/s, one world {p_one:?} (off by {:.1} % of the shot's)",
        100.0 * p_off
    );
    // Every single world conserves momentum to round-off, whatever its order; the split does
    // not, since each world keeps its own crate's share of a solve the others ran in another
    // order (measured 3.7-14.6 % of the shot's momentum on these three shots; exact would
    // take one world solving the whole block, see DESIGN "Not done"). A contact applied by
    // two sides adds the hit a second time, more than half the shot's momentum.
    assert!(
        p_off <= 0.25,
        "{test}: momentum {p_split:?} kg m/s, one world {p_one:?}: off by {:.1} % of the shot's",
        100.0 * p_off
    );
    let mut beyond = Vec::new();
    for (i, id) in corner.bodies().iter().enumerate() {
        let name = QUADRANTS.get(i).map_or("ball", |q| q.0);
        let off = norm(minus(split[id], truth[id]));
        let scale = if i < 4 {
            largest
        } else {
            norm(corner.ball_velocity)
        };
        let allowed = (1.5 * floor[id]).max(0.10 * scale);
        let line = format!(
            "{name} {:?} m/s, one world {:?}: off by {off:.3}, floor {:.3}, allowed {allowed:.3}",
            split[id], truth[id], floor[id]
        );
        println!("{test}: {line}");
        if off > allowed {
            beyond.push(line);
        }
    }
    assert!(beyond.is_empty(), "{test}: beyond the floor: {beyond:#?}");
}

/// A shot from the west along the seam between north and south, into the north-west and
/// south-west crates at once: both push on into the east crates, every contact of the block
/// seen by all four clusters.
#[test]
fn a_shot_along_a_seam_into_a_block_at_the_corner_moves_it_as_one_world() {
    let corner = Corner::new([-20.0, 0.25, 0.0], [0.0, 0.25, 0.0]);
    assert_as_in_one_world(&corner, "corner_along");
}

/// A shot diagonally through the corner point from the south-west, into the south-west crate's
/// corner: that crate is pushed into the other three.
#[test]
fn a_diagonal_shot_into_a_block_at_the_corner_moves_it_as_one_world() {
    let corner = Corner::new([-14.0, -13.0, 0.0], [-0.5, -0.4, 0.0]);
    assert_as_in_one_world(&corner, "corner_diagonal");
}

/// A shot owned by a cluster whose crate it misses: from high in the north-west, over the seam
/// onto the north-east crate's top, which its owner, the shooter's cluster and the south-east
/// cluster (whose crate it is driven into) all model.
#[test]
fn a_shot_from_another_cluster_into_the_corner_block_moves_it_as_one_world() {
    let corner = Corner::new([-5.0, 20.0, 0.0], [0.5, 0.75, 0.0]);
    assert_as_in_one_world(&corner, "corner_across");
}
