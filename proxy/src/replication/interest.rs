//! Which neighbour entities a cluster models.
//!
//! > A neighbour entity is modelled when its **extent** — the box its shape covers at its
//! > replicated pose, grown by the way it sweeps before the next frame can replace that pose —
//! > overlaps this cluster's region grown by the spread, or the room around one of this
//! > cluster's own bodies that is outside that region.
//!
//! The extent, not the centre: a 40 m floor's centre is far from the seam its surface reaches,
//! and a body standing on it across the seam must find it. The sweep: a projectile replicated
//! 3 m short of the region at 300 m/s is inside it before the next frame, so it is modelled
//! before it arrives. The room around the cluster's own bodies: a body this cluster owns that
//! has left its region (a shot in flight, a crate pushed over the seam before a hand-off) meets
//! what is there, so what is there is modelled, for as long as the body is.
//!
//! Game code can add to it: [`Cluster::watch`](crate::Cluster::watch) models what lies in a
//! region for some ticks — the reach of a query about to run (an explosion's radius, a long
//! raycast), which the spread alone may not cover.
//!
//! Whether an entity is *owned* somewhere is decided on its centre instead (see
//! `crate::authority` and `crate::authority::adoption`): ownership is one cluster's, and an extent can lie
//! in several regions at once.

use seam_sim::box_grid::BoxGrid;
use seam_sim::wire::{EntityState, Shape};

use crate::world::Region;

/// The box `state`'s shape covers at its pose, grown along its linear velocity by the way it
/// moves in `sweep_s` seconds (rotation during the sweep is left out: the box already holds
/// every orientation's reach from the centre only for balls, so fast-spinning long bodies can
/// reach a little further than this says).
pub fn extent(state: &EntityState, sweep_s: f32) -> Region {
    let half = half_extent(&state.body.shape, state.rotation);
    let p = state.position;
    let mut region = Region {
        min: [p[0] - half[0], p[1] - half[1], p[2] - half[2]],
        max: [p[0] + half[0], p[1] + half[1], p[2] + half[2]],
    };
    for k in 0..3 {
        let way = state.linvel[k] * sweep_s;
        if way.is_finite() {
            if way < 0.0 {
                region.min[k] += way;
            } else {
                region.max[k] += way;
            }
        }
    }
    region
}

/// Half the size of the axis-aligned box around `shape` turned by `rotation` (`[x, y, z, w]`).
fn half_extent(shape: &Shape, rotation: [f32; 4]) -> [f32; 3] {
    match *shape {
        Shape::Ball { radius } => [radius; 3],
        Shape::Cuboid { half_extents } => {
            let m = matrix(rotation);
            [0, 1, 2].map(|i| (0..3).map(|j| m[i][j].abs() * half_extents[j]).sum())
        }
        Shape::Capsule {
            half_height,
            radius,
        } => {
            // The segment along the local y axis, turned, plus the radius all round.
            let m = matrix(rotation);
            [0, 1, 2].map(|i| m[i][1].abs() * half_height + radius)
        }
        // A sphere about the origin holding the whole shape, however turned.
        Shape::Catalog { bound, .. } => [bound; 3],
    }
}

/// The rotation matrix of a unit quaternion `[x, y, z, w]` (rows).
fn matrix([x, y, z, w]: [f32; 4]) -> [[f32; 3]; 3] {
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
        ],
        [
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
        ],
        [
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// Cell side of the grid the rooms around this cluster's bodies are filed in, m: about a room's
/// size (a body's extent grown by the spread).
const ROOM_GRID_CELL_M: f32 = 4.0;

/// Where a cluster models neighbour entities this tick.
#[derive(Debug, Clone)]
pub(crate) struct Interest {
    /// The region grown by the spread.
    around_region: Option<Region>,
    /// The room around each of this cluster's own bodies that is outside `around_region`:
    /// its extent with its sweep, grown by the spread.
    around_bodies: Vec<Region>,
    /// `around_bodies` filed in a grid, so that a query looks only at the rooms near it.
    rooms: BoxGrid,
    /// The box around every room in `around_bodies` (`None` without any): most neighbour
    /// entities lie outside it, and a query for them ends there.
    rooms_bound: Option<Region>,
    /// Regions watched on request, each until a tick (see `Cluster::watch`).
    watched: Vec<(Region, u64)>,
}

impl Interest {
    /// Interest in `region` grown by `spread`, and nowhere else yet.
    pub(crate) fn new(region: Region, spread: f32) -> Self {
        Self {
            around_region: Some(region.grown(spread)),
            around_bodies: Vec::new(),
            rooms: BoxGrid::new(ROOM_GRID_CELL_M),
            rooms_bound: None,
            watched: Vec::new(),
        }
    }

    /// Watches `region` up to and including tick `until`.
    pub(crate) fn watch(&mut self, region: Region, until: u64) {
        self.watched.push((region, until));
    }

    /// Stops watching what was watched only until before `tick`.
    pub(crate) fn expire(&mut self, tick: u64) {
        self.watched.retain(|&(_, until)| until >= tick);
    }

    /// Replaces the room around this cluster's own bodies with that of `owned` (their extents
    /// with a sweep of `sweep_s`), grown by `spread`, keeping only what reaches outside the
    /// region's.
    pub(crate) fn follow<'a>(
        &mut self,
        owned: impl Iterator<Item = &'a EntityState>,
        sweep_s: f32,
        spread: f32,
    ) {
        self.around_bodies.clear();
        self.rooms.clear();
        self.rooms_bound = None;
        for state in owned {
            let room = extent(state, sweep_s).grown(spread);
            if !self.around_region.is_some_and(|r| r.contains(&room)) {
                self.rooms
                    .insert(self.around_bodies.len() as u32, room.min, room.max);
                self.around_bodies.push(room);
                self.rooms_bound = Some(self.rooms_bound.map_or(room, |b| b.union(&room)));
            }
        }
        self.rooms.seal();
    }

    /// Whether a neighbour entity with this extent is modelled.
    pub(crate) fn covers(&self, extent: &Region) -> bool {
        self.around_region.is_some_and(|r| r.overlaps(extent))
            || (self.rooms_bound.is_some_and(|b| b.overlaps(extent))
                && self.rooms.any(extent.min, extent.max, |i| {
                    self.around_bodies[i as usize].overlaps(extent)
                }))
            || self.watched.iter().any(|(r, _)| r.overlaps(extent))
    }
}

#[cfg(test)]
mod tests {
    use seam_sim::wire::{BodySpec, ClusterId, EntityId};

    use super::*;

    fn state(
        shape: Shape,
        position: [f32; 3],
        rotation: [f32; 4],
        linvel: [f32; 3],
    ) -> EntityState {
        let body = BodySpec::new(shape).density(1.0);
        EntityState::new(EntityId::random(), ClusterId::random(), body)
            .at(position)
            .rotated(rotation)
            .velocity(linvel)
    }

    const IDENTITY: [f32; 4] = [0.0, 0.0, 0.0, 1.0];

    fn close(a: [f32; 3], b: [f32; 3]) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-4)
    }

    #[test]
    fn a_floor_reaches_the_seam_its_centre_is_far_from() {
        let floor = state(
            Shape::Cuboid {
                half_extents: [20.0, 0.5, 20.0],
            },
            [20.0, -0.5, 0.0],
            IDENTITY,
            [0.0; 3],
        );
        let west = Region {
            min: [-40.0, -5.0, -20.0],
            max: [0.0, 30.0, 20.0],
        };
        let mut interest = Interest::new(west, 2.0);
        assert!(interest.covers(&extent(&floor, 0.0)));
        interest = Interest::new(
            Region {
                min: [-40.0, -5.0, -20.0],
                max: [-3.0, 30.0, 20.0],
            },
            2.0,
        );
        assert!(!interest.covers(&extent(&floor, 0.0)), "1 m short");
    }

    #[test]
    fn turned_boxes_and_capsules() {
        // A 2 × 0.2 × 0.2 m plank turned 90° about z stands along y.
        let s = std::f32::consts::FRAC_1_SQRT_2;
        let plank = state(
            Shape::Cuboid {
                half_extents: [1.0, 0.1, 0.1],
            },
            [0.0; 3],
            [0.0, 0.0, s, s],
            [0.0; 3],
        );
        let e = extent(&plank, 0.0);
        assert!(close(e.max, [0.1, 1.0, 0.1]), "{e:?}");
        // A capsule lying along x (turned 90° about z).
        let capsule = state(
            Shape::Capsule {
                half_height: 1.0,
                radius: 0.25,
            },
            [0.0; 3],
            [0.0, 0.0, s, s],
            [0.0; 3],
        );
        let e = extent(&capsule, 0.0);
        assert!(close(e.max, [1.25, 0.25, 0.25]), "{e:?}");
    }

    #[test]
    fn a_fast_body_is_modelled_before_it_arrives() {
        let shot = state(
            Shape::Ball { radius: 0.05 },
            [-10.0, 1.0, 0.0],
            IDENTITY,
            [300.0, 0.0, 0.0],
        );
        let east = Interest::new(
            Region {
                min: [0.0, -5.0, -20.0],
                max: [40.0, 30.0, 20.0],
            },
            2.0,
        );
        assert!(!east.covers(&extent(&shot, 0.0)));
        // Two ticks at 60 Hz: 10 m.
        assert!(east.covers(&extent(&shot, 2.0 / 60.0)));
    }

    #[test]
    fn room_around_own_bodies_outside_the_region() {
        let west = Region {
            min: [-40.0, -5.0, -20.0],
            max: [0.0, 30.0, 20.0],
        };
        let mut interest = Interest::new(west, 2.0);
        let target = state(
            Shape::Ball { radius: 0.5 },
            [15.0, 1.0, 0.0],
            IDENTITY,
            [0.0; 3],
        );
        assert!(!interest.covers(&extent(&target, 0.0)));
        let inside = state(
            Shape::Ball { radius: 0.5 },
            [-5.0, 1.0, 0.0],
            IDENTITY,
            [0.0; 3],
        );
        let pushed_over = state(
            Shape::Ball { radius: 0.5 },
            [13.0, 1.0, 0.0],
            IDENTITY,
            [0.0; 3],
        );
        interest.follow([&inside, &pushed_over].into_iter(), 0.0, 2.0);
        assert_eq!(interest.around_bodies.len(), 1, "only the body outside");
        assert!(interest.covers(&extent(&target, 0.0)));
    }
}
