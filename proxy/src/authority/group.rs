//! Group authority: bodies in sustained contact share one owner (see the module docs of
//! `crate::authority`).
//!
//! > Two bodies that have touched in this cluster's world for `form_frames` replication frames
//! > (gaps of up to `keep_frames` allowed) are bound; bound bodies form groups (connected
//! > components). A group of at most `max_size` bodies, holding bodies of at least
//! > `min_owners` clusters, none moving faster than `rest_speed` against its **anchor** (its
//! > body with the smallest id), has one owner: the anchor's. The anchor moves by the
//! > spatial rule; this cluster hands every body of the group it owns to the anchor's owner —
//! > in the same frame as the anchor, when it hands the anchor itself. A body in no such
//! > group moves by the spatial rule; one taken over lately and moving slowly stays put for
//! > `keep_frames`.
//!
//! Every cluster computes the anchor from what its own world shows, so no negotiation is
//! needed; two clusters that see a group alike pick the same anchor, and a cluster only ever
//! hands its bodies towards that anchor's owner, so no two hand bodies of one group to each
//! other. Views can differ at a group's edge (a proxy just out of one cluster's interest); the
//! hysteresis keeps that from thrashing.

use std::collections::{HashMap, HashSet};
use std::hash::BuildHasherDefault;

use seam_sim::wire::{ClusterId, EntityId, IdHasher};

use super::policy::{AuthorityPolicy, AuthorityView, Touching};
use super::spatial::{Spatial, SpatialSettings};

/// Maps and sets keyed by ids, hashed by [`IdHasher`]: fast, and iterated in the same order on
/// every run (lock-step runs stay deterministic).
type Map<K, V> = HashMap<K, V, BuildHasherDefault<IdHasher>>;
type Set<K> = HashSet<K, BuildHasherDefault<IdHasher>>;

/// The settings of [`Group`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroupSettings {
    /// Replication frames two bodies must touch before they are bound into one group.
    pub form_frames: u32,
    /// Frames two bound bodies may stop touching and stay bound.
    pub keep_frames: u32,
    /// The largest group given one owner; bodies of a larger one (a pile of hundreds) move by
    /// the spatial rule, each on its own.
    pub max_size: usize,
    /// The fewest owners a group's bodies must have (as this cluster sees them) for the group
    /// to be given one: 2 unifies every group across a seam; 3 only where three or more
    /// clusters' bodies touch (a corner), leaving a contact between two clusters to coupling.
    pub min_owners: usize,
    /// The fastest any body of a group may move against its anchor, m/s, for the group to be
    /// given one owner: bodies resting on each other (a stack, riders on a platform), not a
    /// stack toppling or a pile being blown apart, whose bodies change hands mid-collision
    /// otherwise.
    pub rest_speed: f32,
    /// The spatial rule, for each group's anchor and every body in no group.
    pub spatial: SpatialSettings,
}

impl Default for GroupSettings {
    /// Groups of up to 16 bodies that have touched for 30 frames (half a second at 60 Hz),
    /// kept for 60 frames after they stop, where three or more clusters' bodies meet; the
    /// spatial rule's defaults (see the module docs of `crate::authority` for the figures).
    fn default() -> Self {
        Self {
            form_frames: 30,
            keep_frames: 60,
            max_size: 16,
            min_owners: 3,
            rest_speed: 0.5,
            spatial: SpatialSettings::default(),
        }
    }
}

/// The owner and linear velocity of each body in a touching pair, as this world knows them.
type Bodies = Map<EntityId, (ClusterId, [f32; 3])>;

fn bodies_touching(touching: &[Touching]) -> Bodies {
    touching
        .iter()
        .flat_map(|t| {
            [
                (t.a, (t.a_owner, t.a_linvel)),
                (t.b, (t.b_owner, t.b_linvel)),
            ]
        })
        .collect()
}

/// When two bodies touched: first, and last, frame.
#[derive(Debug, Clone, Copy)]
struct Bond {
    first: u64,
    last: u64,
}

/// Bodies in sustained contact share one owner; the rest follow the spatial rule (see the
/// module docs).
#[derive(Debug, Clone, Default)]
pub struct Group {
    settings: GroupSettings,
    spatial: Spatial,
    /// Pairs (smaller id first) seen touching, and when.
    bonds: Map<(EntityId, EntityId), Bond>,
    /// Bodies owned that have been handed over at least once, with the hand-off count (epoch)
    /// they were taken over with and the frame they were taken at.
    taken: Map<EntityId, (u32, u64)>,
    /// The frame count (frames this policy was asked at).
    frame: u64,
}

impl Group {
    /// The policy with these settings.
    pub fn new(settings: GroupSettings) -> Self {
        Self {
            settings,
            spatial: Spatial::new(settings.spatial),
            bonds: Map::default(),
            taken: Map::default(),
            frame: 0,
        }
    }

    /// Notes when the bodies owned now were taken over (a body's epoch counts its hand-offs),
    /// and returns those taken over less than `keep_frames` ago that move slowly (less than
    /// the spatial margin in a frame): they are held where they are, not handed on by the
    /// spatial rule, so a body handed to a group's owner stays while that owner's world has
    /// yet to see the group form (it would hand the body straight back: measured on
    /// `platform`, a rider in transit 19 frames in a row).
    fn held(&mut self, view: &AuthorityView<'_>) -> Set<EntityId> {
        let frame = self.frame;
        let keep = u64::from(self.settings.keep_frames);
        let margin = self.settings.spatial.margin;
        let before = std::mem::take(&mut self.taken);
        let mut held = Set::default();
        for (state, _) in view.owned.iter().filter(|(s, _)| s.epoch > 0) {
            let since = match before.get(&state.id) {
                Some(&(epoch, since)) if epoch == state.epoch => since,
                // Owned from the first frame: not taken over while this policy looked.
                _ if frame == 1 => 0,
                _ => frame,
            };
            self.taken.insert(state.id, (state.epoch, since));
            let speed = state.linvel.iter().map(|v| v * v).sum::<f32>().sqrt();
            if since > 0 && since + keep > frame && speed * view.lookahead_s < margin {
                held.insert(state.id);
            }
        }
        held
    }

    /// Notes this frame's touching pairs and forgets bonds unseen for `keep_frames`.
    fn observe(&mut self, touching: &[Touching]) {
        self.frame += 1;
        let frame = self.frame;
        for t in touching {
            let key = if t.a <= t.b { (t.a, t.b) } else { (t.b, t.a) };
            self.bonds
                .entry(key)
                .and_modify(|b| b.last = frame)
                .or_insert(Bond {
                    first: frame,
                    last: frame,
                });
        }
        let keep = u64::from(self.settings.keep_frames);
        self.bonds.retain(|_, b| b.last + keep >= frame);
    }

    /// The groups of bound bodies, each as its members, smallest id first.
    fn groups(&self) -> Vec<Vec<EntityId>> {
        let form = u64::from(self.settings.form_frames.max(1));
        let mut sets = Sets::default();
        for (&(a, b), bond) in &self.bonds {
            if self.frame + 1 >= bond.first + form {
                sets.join(a, b);
            }
        }
        sets.groups()
    }
}

impl Group {
    /// The anchor of each body this cluster (`me`) owns that is in a group given one owner:
    /// at most `max_size` bodies, of at least `min_owners` owners, none moving faster than
    /// `rest_speed` against the anchor (owners and velocities from `touching`, as this world
    /// knows them: [`bodies_touching`]).
    fn anchors(&self, bodies: &Bodies, me: ClusterId) -> Map<EntityId, EntityId> {
        if bodies.is_empty() {
            return Map::default();
        }
        let owner = |id: &EntityId| bodies.get(id).map(|b| b.0);
        let linvel = |id: &EntityId| bodies.get(id).map_or([0.0; 3], |b| b.1);
        let mut anchor_of = Map::default();
        for group in self.groups() {
            if group.len() > self.settings.max_size {
                continue;
            }
            let mut group_owners: Vec<ClusterId> = group.iter().filter_map(owner).collect();
            group_owners.sort_unstable();
            group_owners.dedup();
            if group_owners.len() < self.settings.min_owners {
                continue;
            }
            let anchor = group[0];
            let at = linvel(&anchor);
            let resting = group.iter().all(|m| {
                let v = linvel(m);
                (0..3).map(|k| (v[k] - at[k]).powi(2)).sum::<f32>().sqrt()
                    <= self.settings.rest_speed
            });
            if !resting {
                continue;
            }
            for member in group {
                if owner(&member) == Some(me) {
                    anchor_of.insert(member, anchor);
                }
            }
        }
        anchor_of
    }

    /// The spatial rule's hand-offs for every owned body but those grouped under another's
    /// anchor and those `held`.
    fn spatial_handoffs(
        &mut self,
        view: &AuthorityView<'_>,
        anchor_of: &Map<EntityId, EntityId>,
        held: &Set<EntityId>,
    ) -> Vec<(EntityId, ClusterId)> {
        let mut spatial = Vec::new();
        if anchor_of.is_empty() && held.is_empty() {
            self.spatial.decide(view, &mut spatial);
            return spatial;
        }
        let owned: Vec<_> = view
            .owned
            .iter()
            .filter(|(state, _)| anchor_of.get(&state.id).is_none_or(|&a| a == state.id))
            .filter(|(state, _)| !held.contains(&state.id))
            .copied()
            .collect();
        let view = AuthorityView {
            owned: &owned,
            ..*view
        };
        self.spatial.decide(&view, &mut spatial);
        spatial
    }
}

impl AuthorityPolicy for Group {
    fn touching_budget(&self, clusters: usize) -> usize {
        if clusters < self.settings.min_owners {
            // No group can hold bodies of enough owners (two clusters, groups where three
            // meet): every body goes by the spatial rule, and nothing is walked for groups.
            return 0;
        }
        // One more than a group may hold tells a group too large.
        self.settings.max_size + 1
    }

    fn decide(&mut self, view: &AuthorityView<'_>, handoffs: &mut Vec<(EntityId, ClusterId)>) {
        if view.neighbours.is_empty() {
            return;
        }
        self.observe(view.touching);
        let held = self.held(view);
        let bodies = bodies_touching(view.touching);
        let anchor_of = self.anchors(&bodies, view.cluster);
        let spatial = self.spatial_handoffs(view, &anchor_of, &held);
        // An anchor the spatial rule hands over takes this cluster's members of its group along.
        let anchors_handed: Map<EntityId, ClusterId> = spatial
            .iter()
            .filter(|(id, _)| anchor_of.get(id) == Some(id))
            .copied()
            .collect();
        handoffs.extend(spatial);
        let live = |c: ClusterId| view.neighbours.iter().any(|n| n.id == c && n.alive);
        let mut members: Vec<(EntityId, EntityId)> = anchor_of
            .iter()
            .filter(|(m, a)| m != a)
            .map(|(&m, &a)| (m, a))
            .collect();
        members.sort_unstable();
        for (member, anchor) in members {
            let owner = bodies.get(&anchor).map(|b| b.0);
            let Some(to) = anchors_handed.get(&anchor).copied().or(owner) else {
                continue;
            };
            if to != view.cluster && live(to) {
                handoffs.push((member, to));
            }
        }
    }
}

/// Disjoint sets of entities (union-find).
#[derive(Default)]
struct Sets {
    parent: Map<EntityId, EntityId>,
}

impl Sets {
    fn root(&mut self, id: EntityId) -> EntityId {
        let mut at = id;
        while let Some(&up) = self.parent.get(&at) {
            if up == at {
                break;
            }
            at = up;
        }
        self.parent.insert(id, at);
        at
    }

    fn join(&mut self, a: EntityId, b: EntityId) {
        let (ra, rb) = (self.root(a), self.root(b));
        // The smaller id is the root, so a group's root is its anchor.
        let (low, high) = if ra <= rb { (ra, rb) } else { (rb, ra) };
        self.parent.insert(high, low);
        self.parent.insert(low, low);
    }

    /// Each set, smallest id first.
    fn groups(mut self) -> Vec<Vec<EntityId>> {
        let ids: Vec<EntityId> = self.parent.keys().copied().collect();
        let mut by_root: Map<EntityId, Vec<EntityId>> = Map::default();
        for id in ids {
            let root = self.root(id);
            by_root.entry(root).or_default().push(id);
        }
        let mut groups: Vec<Vec<EntityId>> = by_root
            .into_values()
            .map(|mut g| {
                g.sort_unstable();
                g
            })
            .collect();
        groups.sort_unstable();
        groups
    }
}

#[cfg(test)]
mod tests {
    use seam_sim::BodyRole;
    use seam_sim::wire::{BodySpec, EntityState, Shape};

    use super::*;
    use crate::authority::NeighbourView;
    use crate::world::Region;

    fn cluster(n: u128) -> ClusterId {
        ClusterId::from_u128(n)
    }

    fn id(n: u128) -> EntityId {
        EntityId::from_u128(n)
    }

    /// Four clusters round the origin (1: x < 0, z < 0; 2: x > 0, z < 0; 3: x < 0, z > 0;
    /// 4: x > 0, z > 0); the one asking is `me`.
    fn region_of(c: u128) -> Region {
        let (x, z) = match c {
            1 => (-20.0, -20.0),
            2 => (0.0, -20.0),
            3 => (-20.0, 0.0),
            _ => (0.0, 0.0),
        };
        Region {
            min: [x, -10.0, z],
            max: [x + 20.0, 10.0, z + 20.0],
        }
    }

    fn body(n: u128, owner: u128, at: [f32; 3]) -> (EntityState, BodyRole) {
        let spec = BodySpec::new(Shape::cuboid(0.5, 0.5, 0.5)).density(100.0);
        let mut state = EntityState::new(id(n), cluster(owner), spec).at(at);
        state.epoch = 0;
        (state, BodyRole::Dynamic)
    }

    fn touch(a: (u128, u128), b: (u128, u128)) -> Touching {
        Touching {
            a: id(a.0),
            a_owner: cluster(a.1),
            a_linvel: [0.0; 3],
            b: id(b.0),
            b_owner: cluster(b.1),
            b_linvel: [0.0; 3],
        }
    }

    fn decide(
        policy: &mut Group,
        me: u128,
        owned: &[(EntityState, BodyRole)],
        touching: &[Touching],
    ) -> Vec<(EntityId, ClusterId)> {
        let neighbours: Vec<NeighbourView> = (1..=4)
            .filter(|&c| c != me)
            .map(|c| NeighbourView {
                id: cluster(c),
                region: Some(region_of(c)),
                alive: true,
            })
            .collect();
        let view = AuthorityView {
            cluster: cluster(me),
            tick: 0,
            region: region_of(me),
            lookahead_s: 1.0 / 60.0,
            neighbours: &neighbours,
            owned,
            touching,
        };
        let mut out = Vec::new();
        policy.decide(&view, &mut out);
        out
    }

    /// A stack on the corner point: cluster 2's crate (id 20) between cluster 1's (id 10, the
    /// anchor: the smallest id) and cluster 4's (id 40).
    fn corner_stack() -> Vec<Touching> {
        vec![touch((10, 1), (20, 2)), touch((20, 2), (40, 4))]
    }

    #[test]
    fn a_group_of_three_owners_goes_to_its_anchors_owner_once_formed() {
        let settings = GroupSettings::default();
        let mut policy = Group::new(settings);
        let owned = [body(20, 2, [0.05, 1.5, -0.05])];
        for frame in 1..settings.form_frames {
            assert!(
                decide(&mut policy, 2, &owned, &corner_stack()).is_empty(),
                "frame {frame}: not yet a group"
            );
        }
        assert_eq!(
            decide(&mut policy, 2, &owned, &corner_stack()),
            vec![(id(20), cluster(1))],
            "to the anchor's owner"
        );
    }

    #[test]
    fn two_owners_are_left_to_the_spatial_rule_unless_asked() {
        let pair = [touch((10, 1), (20, 2))];
        let owned = [body(20, 2, [0.05, 1.5, -0.05])];
        let mut three = Group::new(GroupSettings::default());
        let mut two = Group::new(GroupSettings {
            min_owners: 2,
            ..GroupSettings::default()
        });
        let mut handed = Vec::new();
        for _ in 0..GroupSettings::default().form_frames {
            assert!(decide(&mut three, 2, &owned, &pair).is_empty());
            handed = decide(&mut two, 2, &owned, &pair);
        }
        assert_eq!(handed, vec![(id(20), cluster(1))]);
    }

    #[test]
    fn a_group_moving_against_its_anchor_is_left_to_the_spatial_rule() {
        let settings = GroupSettings::default();
        let mut policy = Group::new(settings);
        let owned = [body(20, 2, [0.05, 1.5, -0.05])];
        let mut falling = corner_stack();
        falling[1].b_linvel = [0.0, -2.0, 0.0];
        for _ in 0..settings.form_frames + 1 {
            assert!(decide(&mut policy, 2, &owned, &falling).is_empty());
        }
    }

    #[test]
    fn a_group_too_large_is_left_to_the_spatial_rule() {
        let settings = GroupSettings {
            max_size: 2,
            ..GroupSettings::default()
        };
        let mut policy = Group::new(settings);
        let owned = [body(20, 2, [0.05, 1.5, -0.05])];
        for _ in 0..settings.form_frames + 1 {
            assert!(decide(&mut policy, 2, &owned, &corner_stack()).is_empty());
        }
    }

    #[test]
    fn the_anchor_moves_by_the_spatial_rule_and_takes_its_group_along() {
        let settings = GroupSettings::default();
        let mut policy = Group::new(settings);
        // Cluster 1 owns the anchor (10) and 11, both well inside cluster 4's region now.
        let owned = [body(10, 1, [5.0, 0.5, 5.0]), body(11, 1, [5.0, 1.5, 5.0])];
        let touching = [touch((10, 1), (11, 1)), touch((11, 1), (20, 2))];
        let mut handed = Vec::new();
        for _ in 0..settings.form_frames {
            handed = decide(&mut policy, 1, &owned, &touching);
        }
        handed.sort_unstable();
        assert_eq!(handed, vec![(id(10), cluster(4)), (id(11), cluster(4))]);
    }

    #[test]
    fn contacts_are_walked_only_where_enough_clusters_could_meet() {
        let three = Group::new(GroupSettings::default());
        assert_eq!(
            three.touching_budget(2),
            0,
            "two clusters never make three owners"
        );
        assert_eq!(
            three.touching_budget(4),
            GroupSettings::default().max_size + 1
        );
        let two = Group::new(GroupSettings {
            min_owners: 2,
            ..GroupSettings::default()
        });
        assert_eq!(
            two.touching_budget(2),
            GroupSettings::default().max_size + 1
        );
    }

    #[test]
    fn a_body_just_taken_over_is_held_unless_it_moves_fast() {
        let settings = GroupSettings::default();
        let mut policy = Group::new(settings);
        // Owned from the start, inside cluster 2's region: stays.
        let mut owned = vec![body(30, 2, [1.0, 0.5, -1.0])];
        assert!(decide(&mut policy, 2, &owned, &[]).is_empty());
        // Taken over (epoch 1) while well inside cluster 1's region: held, not handed back.
        let (mut slow, role) = body(31, 1, [-5.0, 0.5, -5.0]);
        slow.cluster_id = cluster(2);
        slow.epoch = 1;
        let mut fast = slow;
        fast.id = id(32);
        fast.linvel = [-100.0, 0.0, 0.0];
        owned.extend([(slow, role), (fast, role)]);
        let handed = decide(&mut policy, 2, &owned, &[]);
        assert_eq!(
            handed,
            vec![(id(32), cluster(1))],
            "only the fast one moves on"
        );
        for _ in 0..settings.keep_frames {
            decide(&mut policy, 2, &owned[..2], &[]);
        }
        assert_eq!(
            decide(&mut policy, 2, &owned[..2], &[]),
            vec![(id(31), cluster(1))],
            "held for keep_frames, then the spatial rule"
        );
    }
}
