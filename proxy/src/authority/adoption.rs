//! Who adopts the entities of a neighbour taken for dead.
//!
//! Every survivor computes the same answer from what it was told at start (the world map:
//! every cluster's region and neighbours) and what it knows of liveness, so exactly one
//! cluster adopts each entity without any message between them:
//!
//! > The adopter of an entity of dead cluster `D` is, among `D`'s neighbours not taken for dead,
//! > the one whose region is nearest to the entity's last replicated position; a tie goes to the
//! > smallest cluster id.
//!
//! The rule is only as good as its inputs agree. Survivors hold the same last frame of `D` when
//! `D` died between two publishes (a frame reaches all subscribers or, if `D` died while
//! publishing, may reach some); they agree on liveness unless a candidate is itself dying or
//! partitioned while the others decide. A candidate that is not this cluster's neighbour is
//! assumed alive (this cluster cannot hear it): if it is dead too, its share is not adopted.

use seam_sim::wire::ClusterId;

use crate::world::WorldCluster;

/// The cluster that adopts an entity of `dead` last seen at `position`, or `None` if the world
/// map does not know `dead` or no candidate is alive. `alive` says whether a candidate is taken
/// for alive by the asking cluster.
pub(crate) fn adopter(
    world: &[WorldCluster],
    dead: ClusterId,
    position: [f32; 3],
    alive: impl Fn(ClusterId) -> bool,
) -> Option<ClusterId> {
    let neighbours = &world.iter().find(|c| c.id == dead)?.neighbours;
    world
        .iter()
        .filter(|c| c.id != dead && neighbours.contains(&c.id) && alive(c.id))
        .map(|c| (c.region.distance_squared(position), c.id))
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map(|(_, id)| id)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::Region;

    fn region(x0: f32, x1: f32) -> Region {
        Region {
            min: [x0, -100.0, -100.0],
            max: [x1, 100.0, 100.0],
        }
    }

    /// Three clusters in a row along x: west [-30,-10], middle [-10,10], east [10,30].
    fn row() -> (Vec<WorldCluster>, [ClusterId; 3]) {
        let ids = [1, 2, 3].map(ClusterId::from_u128);
        let world = vec![
            WorldCluster {
                spread: 0.0,
                id: ids[0],
                region: region(-30.0, -10.0),
                neighbours: vec![ids[1]],
            },
            WorldCluster {
                spread: 0.0,
                id: ids[1],
                region: region(-10.0, 10.0),
                neighbours: vec![ids[0], ids[2]],
            },
            WorldCluster {
                spread: 0.0,
                id: ids[2],
                region: region(10.0, 30.0),
                neighbours: vec![ids[1]],
            },
        ];
        (world, ids)
    }

    #[test]
    fn the_nearest_live_neighbour_adopts() {
        let (world, [west, middle, east]) = row();
        let all = |_| true;
        assert_eq!(adopter(&world, middle, [-4.0, 0.0, 0.0], all), Some(west));
        assert_eq!(adopter(&world, middle, [4.0, 0.0, 0.0], all), Some(east));
        // Equally far: the smaller id.
        assert_eq!(adopter(&world, middle, [0.0, 0.0, 0.0], all), Some(west));
        // The nearer one is dead: the other adopts.
        assert_eq!(
            adopter(&world, middle, [-4.0, 0.0, 0.0], |c| c != west),
            Some(east)
        );
        // Only a neighbour of the dead cluster adopts.
        assert_eq!(adopter(&world, west, [-20.0, 0.0, 0.0], all), Some(middle));
        // Nobody left, or an unknown cluster.
        assert_eq!(adopter(&world, west, [0.0; 3], |_| false), None);
        assert_eq!(
            adopter(&world, ClusterId::from_u128(9), [0.0; 3], all),
            None
        );
    }
}
