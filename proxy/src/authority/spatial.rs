//! The built-in policy: authority follows entities through the world's regions (see the
//! module docs of `crate::authority`).

use std::collections::HashMap;

use seam_sim::BodyRole;
use seam_sim::wire::{ClusterId, EntityId};

use super::policy::{AuthorityPolicy, AuthorityView};
/// The settings of [`Spatial`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpatialSettings {
    /// How far past a seam, metres, a body's centre must be before it is handed over (and
    /// before it comes back).
    pub margin: f32,
    /// Frames in a row the same answer must hold (1: at once).
    pub dwell_ticks: u32,
}

impl Default for SpatialSettings {
    fn default() -> Self {
        Self {
            margin: 0.25,
            dwell_ticks: 1,
        }
    }
}

/// Authority follows entities through the world's regions (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct Spatial {
    settings: SpatialSettings,
    /// Entities with a pending answer: the neighbour named and in how many frames in a row.
    pending: HashMap<EntityId, (ClusterId, u32)>,
}

impl Spatial {
    /// The policy with these settings.
    pub fn new(settings: SpatialSettings) -> Self {
        Self {
            settings,
            pending: HashMap::new(),
        }
    }

    /// Where the entity at `p` belongs, if not with its owner.
    fn belongs(&self, view: &AuthorityView<'_>, p: [f32; 3]) -> Option<ClusterId> {
        let margin = self.settings.margin;
        if view.region.contains_within(p, margin) {
            return None;
        }
        let live = || {
            view.neighbours
                .iter()
                .filter(|n| n.alive)
                .filter_map(|n| n.region.map(|r| (n.id, r)))
        };
        if let Some((id, _)) = live().find(|(_, r)| r.contains_within(p, -margin)) {
            return Some(id);
        }
        let own = view.region.distance_squared(p).sqrt();
        live()
            .map(|(id, r)| (r.distance_squared(p).sqrt(), id))
            .filter(|&(d, _)| d + margin < own)
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
            .map(|(_, id)| id)
    }
}

impl AuthorityPolicy for Spatial {
    fn decide(&mut self, view: &AuthorityView<'_>, handoffs: &mut Vec<(EntityId, ClusterId)>) {
        let mut pending = std::mem::take(&mut self.pending);
        let mut still = HashMap::new();
        for (state, role) in view.owned {
            // Bodies that move go with their region; a Fixed one stays with its owner. A
            // platform is handed as a dynamic body is, and keeps its role and velocity.
            if !matches!(role, BodyRole::Dynamic | BodyRole::KinematicVelocityBased) {
                continue;
            }
            let ahead = [0, 1, 2].map(|k| state.position[k] + state.linvel[k] * view.lookahead_s);
            let Some(to) = self.belongs(view, ahead) else {
                continue;
            };
            let frames = match pending.remove(&state.id) {
                Some((named, frames)) if named == to => frames + 1,
                _ => 1,
            };
            if frames >= self.settings.dwell_ticks.max(1) {
                handoffs.push((state.id, to));
            } else {
                still.insert(state.id, (to, frames));
            }
        }
        self.pending = still;
    }
}

#[cfg(test)]
mod tests {
    use seam_sim::wire::{BodySpec, EntityState, Shape};

    use super::*;
    use crate::authority::NeighbourView;
    use crate::world::Region;

    fn region(x0: f32, x1: f32) -> Region {
        Region {
            min: [x0, -100.0, -100.0],
            max: [x1, 100.0, 100.0],
        }
    }

    fn body(x: f32) -> (EntityState, BodyRole) {
        let body = BodySpec::new(Shape::ball(0.5)).density(1.0);
        let id = EntityId::from_u128(x.to_bits() as u128 + 1);
        let state = EntityState::new(id, ClusterId::from_u128(2), body).at([x, 0.0, 0.0]);
        (state, BodyRole::Dynamic)
    }

    /// Three clusters in a row: west [-30,-10], middle (asking) [-10,10], east [10,30].
    fn decide(
        policy: &mut Spatial,
        owned: &[(EntityState, BodyRole)],
        east_alive: bool,
    ) -> Vec<(EntityId, ClusterId)> {
        let neighbours = [
            NeighbourView {
                id: ClusterId::from_u128(1),
                region: Some(region(-30.0, -10.0)),
                alive: true,
            },
            NeighbourView {
                id: ClusterId::from_u128(3),
                region: Some(region(10.0, 30.0)),
                alive: east_alive,
            },
        ];
        let view = AuthorityView {
            cluster: ClusterId::from_u128(2),
            tick: 0,
            region: region(-10.0, 10.0),
            lookahead_s: 1.0 / 60.0,
            neighbours: &neighbours,
            owned,
            touching: &[],
        };
        let mut out = Vec::new();
        policy.decide(&view, &mut out);
        out
    }

    #[test]
    fn hands_over_past_the_margin_only() {
        let mut policy = Spatial::new(SpatialSettings {
            margin: 0.5,
            dwell_ticks: 1,
        });
        let east = ClusterId::from_u128(3);
        let west = ClusterId::from_u128(1);
        for (x, expected) in [
            (0.0, None),
            (10.3, None),
            (-10.4, None),
            (10.6, Some(east)),
            (-10.6, Some(west)),
            // Overshot east into nobody's region: east is nearest.
            (45.0, Some(east)),
        ] {
            let owned = [body(x)];
            let got = decide(&mut policy, &owned, true);
            assert_eq!(got.first().map(|h| h.1), expected, "at x = {x}");
        }
        // Never to a neighbour taken for dead.
        assert!(decide(&mut policy, &[body(12.0)], false).is_empty());
        // Never a Fixed body.
        let mut fixed = body(12.0);
        fixed.1 = BodyRole::Fixed;
        assert!(decide(&mut policy, &[fixed], true).is_empty());
    }

    #[test]
    fn a_fast_body_is_handed_over_before_the_step_that_crosses() {
        let mut policy = Spatial::new(SpatialSettings::default());
        // 9 m short of east at 600 m/s: 10 m in the next 1/60 s.
        let (mut shot, role) = body(1.0);
        shot.linvel = [600.0, 0.0, 0.0];
        let got = decide(&mut policy, &[(shot, role)], true);
        assert_eq!(got.first().map(|h| h.1), Some(ClusterId::from_u128(3)));
        // A slow body there stays.
        assert!(decide(&mut policy, &[body(1.0)], true).is_empty());
    }

    #[test]
    fn dwell_needs_frames_in_a_row() {
        let mut policy = Spatial::new(SpatialSettings {
            margin: 0.25,
            dwell_ticks: 3,
        });
        let owned = [body(12.0)];
        assert!(decide(&mut policy, &owned, true).is_empty());
        assert!(decide(&mut policy, &owned, true).is_empty());
        // Back inside for a frame: the count starts again.
        assert!(decide(&mut policy, &[body(0.0)], true).is_empty());
        assert!(decide(&mut policy, &owned, true).is_empty());
        assert!(decide(&mut policy, &owned, true).is_empty());
        assert_eq!(decide(&mut policy, &owned, true).len(), 1);
    }
}
