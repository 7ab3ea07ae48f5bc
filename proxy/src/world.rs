//! The world as every cluster is told it: regions ([`Region`]) and the map of clusters with
//! their neighbours ([`WorldCluster`], [`world_map`]).

use seam_sim::wire::ClusterId;

/// An axis-aligned box of the world, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// Lowest corner.
    pub min: [f32; 3],
    /// Highest corner.
    pub max: [f32; 3],
}

impl Region {
    /// Everything.
    pub const EVERYWHERE: Region = Region {
        min: [f32::NEG_INFINITY; 3],
        max: [f32::INFINITY; 3],
    };

    /// Squared distance from `point` to the nearest point of the region (0 inside it).
    pub fn distance_squared(&self, point: [f32; 3]) -> f32 {
        (0..3)
            .map(|i| {
                let outside = (self.min[i] - point[i])
                    .max(point[i] - self.max[i])
                    .max(0.0);
                if outside.is_finite() {
                    outside * outside
                } else {
                    0.0
                }
            })
            .sum()
    }

    /// Whether `point` lies within the region grown by `margin` on every side (a negative
    /// margin shrinks it).
    pub fn contains_within(&self, point: [f32; 3], margin: f32) -> bool {
        (0..3).all(|i| point[i] >= self.min[i] - margin && point[i] <= self.max[i] + margin)
    }

    /// The region grown by `margin` on every side.
    pub fn grown(&self, margin: f32) -> Region {
        Region {
            min: self.min.map(|v| v - margin),
            max: self.max.map(|v| v + margin),
        }
    }

    /// The smallest region holding both.
    pub fn union(&self, other: &Region) -> Region {
        Region {
            min: [0, 1, 2].map(|k| self.min[k].min(other.min[k])),
            max: [0, 1, 2].map(|k| self.max[k].max(other.max[k])),
        }
    }

    /// Whether the two boxes touch or overlap.
    pub fn overlaps(&self, other: &Region) -> bool {
        (0..3).all(|i| self.min[i] <= other.max[i] && other.min[i] <= self.max[i])
    }

    /// Whether `other` lies wholly inside this region.
    pub fn contains(&self, other: &Region) -> bool {
        (0..3).all(|i| self.min[i] <= other.min[i] && other.max[i] <= self.max[i])
    }

    /// Whether this region grown by `margin` and `other` grown by `other_margin` touch or
    /// overlap.
    pub fn touches(&self, margin: f32, other: &Region, other_margin: f32) -> bool {
        let margin = margin + other_margin;
        (0..3).all(|k| self.min[k] <= other.max[k] + margin && other.min[k] <= self.max[k] + margin)
    }
}

/// One cluster of the world, as every cluster is told it.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldCluster {
    /// The cluster.
    pub id: ClusterId,
    /// The part of the world it observes.
    pub region: Region,
    /// The clusters whose entities it sees and writes to.
    pub neighbours: Vec<ClusterId>,
    /// How far beyond its region it models neighbour entities (its `ClusterConfig::spread`):
    /// what a hand-off to it is checked against (see `Cluster::transfer_authority`). 0 where
    /// not known: then taken to be the spread of the cluster checking.
    pub spread: f32,
}

/// The world map of clusters given as (id, region, spread): each cluster's neighbours are those
/// whose region, grown by its spread, touches its own grown by its spread — the clusters whose
/// entities it may model. Give every cluster the whole map (`ClusterConfig::world`) and its
/// own entry's neighbours (`ClusterConfig::neighbours`).
pub fn world_map(clusters: &[(ClusterId, Region, f32)]) -> Vec<WorldCluster> {
    clusters
        .iter()
        .map(|&(id, region, spread)| WorldCluster {
            id,
            region,
            spread,
            neighbours: clusters
                .iter()
                .filter(|(other, ..)| *other != id)
                .filter(|(_, other, other_spread)| region.touches(spread, other, *other_spread))
                .map(|(other, ..)| *other)
                .collect(),
        })
        .collect()
}
