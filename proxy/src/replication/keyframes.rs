//! Sending only what changed: a full replication frame (a keyframe) every
//! `ClusterConfig::keyframe_ticks`, and between keyframes delta frames that list the states
//! changed since the keyframe and mark the keyframe's others unchanged, one bit each.
//!
//! A body at rest (asleep, or exactly still) costs one bit a frame instead of a record. A
//! receiver reads a delta frame against the keyframe it names, which gives exactly the states
//! a full frame would have listed: the same proxies, the same accuracy. Losses stay bounded by
//! the keyframe interval:
//!
//! - a lost delta frame costs nothing: every delta frame lists everything changed since its
//!   keyframe, so the next one says it all again;
//! - a lost keyframe leaves the delta frames after it without a base: the receiver uses what
//!   they list and keeps the rest of its picture, despawning nothing, until the next keyframe
//!   makes it whole. So that this picture lacks no entity, a delta frame also lists every
//!   state its sender's keyframe *before* the current one did not hold (entities new since
//!   then): they are the only ones a receiver missing one keyframe has never seen.

use seam_sim::wire::{ClusterId, DeltaBase, EntityId, EntityState, IdMap};

/// What kind of frame to publish.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Plan {
    /// A keyframe: every state.
    Key,
    /// A delta frame read against the keyframe of this tick, which listed this many states.
    Delta { key_tick: u64, key_states: u32 },
}

/// The sender's side: the last keyframe's states, by entity, with their place in it.
#[derive(Debug, Default)]
pub(crate) struct Keyframes {
    /// Frames from one keyframe to the next (1: every frame is one).
    every: u64,
    /// Frames published since the last keyframe.
    since: u64,
    key_tick: Option<u64>,
    key: IdMap<EntityId, (u32, EntityState)>,
    key_states: u32,
    /// The entities of the keyframe before, or `None` before the second keyframe.
    earlier: Option<IdMap<EntityId, ()>>,
    unchanged: Vec<u8>,
}

impl Keyframes {
    /// A keyframe every `keyframe_ticks` ticks (rounded up to whole frames of
    /// `replication_interval` ticks; 0 or 1: every frame).
    pub(crate) fn new(keyframe_ticks: u64, replication_interval: u64) -> Self {
        Self {
            every: keyframe_ticks.div_ceil(replication_interval.max(1)).max(1),
            ..Self::default()
        }
    }

    /// Decides this frame's kind. For a delta frame, takes the unchanged states out of
    /// `states` and marks them in the bitmap ([`Self::base`]); for a keyframe, remembers every
    /// state. `me` is the sender: only its own current states can be unchanged (a hand-off
    /// always rides whole).
    pub(crate) fn plan(&mut self, me: ClusterId, tick: u64, states: &mut Vec<EntityState>) -> Plan {
        let key_tick = match self.key_tick {
            Some(key_tick) if self.since + 1 < self.every => key_tick,
            _ => {
                self.remember(tick, states);
                return Plan::Key;
            }
        };
        self.since += 1;
        self.unchanged.clear();
        self.unchanged
            .resize((self.key_states as usize).div_ceil(8), 0);
        let (key, earlier, bits) = (&self.key, &self.earlier, &mut self.unchanged);
        // Frames list a cluster's entities in the same order from one to the next, so each is
        // looked for first where the one before it was found, plus one (no hashing).
        let mut next = 0;
        states.retain(|state| {
            if state.cluster_id != me || state.tick != tick {
                return true;
            }
            let then = match key.get_index(next) {
                Some((id, then)) if *id == state.id => Some((next, then)),
                _ => key.get_full(&state.id).map(|(i, _, then)| (i, then)),
            };
            let Some((i, &(j, ref then))) = then else {
                return true;
            };
            next = i + 1;
            let same = then.tick == key_tick
                && EntityState { tick, ..*then } == *state
                && earlier.as_ref().is_none_or(|e| e.contains_key(&state.id));
            if same {
                bits[j as usize / 8] |= 1 << (j % 8);
            }
            !same
        });
        Plan::Delta {
            key_tick,
            key_states: self.key_states,
        }
    }

    /// What the delta frame just planned is read against.
    pub(crate) fn base(&self, key_tick: u64, key_states: u32) -> DeltaBase<'_> {
        DeltaBase {
            key_tick,
            key_states,
            unchanged: &self.unchanged,
        }
    }

    fn remember(&mut self, tick: u64, states: &[EntityState]) {
        let mut earlier = self.earlier.take().unwrap_or_default();
        earlier.clear();
        let had_key = self.key_tick.is_some();
        earlier.extend(self.key.keys().map(|&id| (id, ())));
        self.earlier = had_key.then_some(earlier);
        self.key.clear();
        self.key.extend(
            states
                .iter()
                .enumerate()
                .map(|(j, s)| (s.id, (j as u32, *s))),
        );
        self.key_states = states.len() as u32;
        self.key_tick = Some(tick);
        self.since = 0;
    }
}

#[cfg(test)]
mod tests {
    use seam_sim::wire::{BodySpec, Shape};

    use super::*;

    fn ball(id: EntityId, owner: ClusterId, tick: u64, x: f32) -> EntityState {
        let mut state =
            EntityState::new(id, owner, BodySpec::new(Shape::ball(0.5))).at([x, 0.0, 0.0]);
        state.tick = tick;
        state
    }

    #[test]
    fn still_bodies_are_marked_moving_ones_listed_and_keyframes_come_on_time() {
        let me = ClusterId::random();
        let (still, moving) = (EntityId::random(), EntityId::random());
        let mut keyframes = Keyframes::new(4, 1);
        let mut plans = Vec::new();
        for tick in 0..9 {
            let mut states = vec![
                ball(still, me, tick, 1.0),
                ball(moving, me, tick, tick as f32),
            ];
            let plan = keyframes.plan(me, tick, &mut states);
            plans.push(plan);
            match plan {
                Plan::Key => assert_eq!(states.len(), 2),
                Plan::Delta { key_states, .. } => {
                    assert_eq!(key_states, 2);
                    // Before the second keyframe everything new since "the one before" is
                    // unknown, so only the keyframe decides.
                    let listed: Vec<EntityId> = states.iter().map(|s| s.id).collect();
                    assert_eq!(listed, vec![moving], "tick {tick}");
                    let base = keyframes.base(0, key_states);
                    assert!(base.is_unchanged(0) && !base.is_unchanged(1));
                }
            }
        }
        let keys: Vec<usize> = (0..9).filter(|&t| plans[t] == Plan::Key).collect();
        assert_eq!(keys, vec![0, 4, 8]);
    }

    #[test]
    fn an_entity_the_keyframe_before_lacked_is_listed_until_two_keyframes_hold_it() {
        let me = ClusterId::random();
        let (old, new) = (EntityId::random(), EntityId::random());
        let mut keyframes = Keyframes::new(2, 1);
        let mut listed = Vec::new();
        for tick in 0..7 {
            let mut states = vec![ball(old, me, tick, 1.0)];
            if tick >= 1 {
                states.push(ball(new, me, tick, 2.0));
            }
            let plan = keyframes.plan(me, tick, &mut states);
            if matches!(plan, Plan::Delta { .. }) {
                listed.push((tick, states.iter().any(|s| s.id == new)));
            }
        }
        // Keyframes at 0, 2, 4, 6: `new` is in the keyframe of 2 but not of 0, so the delta
        // frame of 3 lists it; from the keyframe of 4 on, two keyframes hold it.
        assert_eq!(listed, vec![(1, true), (3, true), (5, false)]);
    }

    #[test]
    fn a_handoff_is_always_listed() {
        let (me, other) = (ClusterId::random(), ClusterId::random());
        let id = EntityId::random();
        let mut keyframes = Keyframes::new(10, 1);
        let mut states = vec![ball(id, other, 0, 1.0)];
        keyframes.plan(me, 0, &mut states);
        let mut states = vec![ball(id, other, 1, 1.0)];
        assert!(matches!(
            keyframes.plan(me, 1, &mut states),
            Plan::Delta { .. }
        ));
        assert_eq!(states.len(), 1);
    }
}
