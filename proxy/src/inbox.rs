//! Frames received and not yet used, by sender and tick.
//!
//! A frame is tagged with the number of steps its sender had taken when it published. In
//! lock-step a cluster that has taken `n` steps uses exactly the frames tagged `n` and keeps
//! later ones for later ticks, so what it sees does not depend on how fast a transport
//! delivered: the same run gives the same result on every transport.

use std::collections::BTreeMap;
use std::collections::btree_map::Entry;
use std::sync::Arc;

use seam_sim::wire::{
    ClusterId, EntityId, EntityState, IdMap, PhysicsEventsFrame, ReplicationView, WireError,
};

/// A replication frame as received: its bytes, whose header and sizes were checked when it
/// arrived and whose states are read in place when it is used (no decode pass), the keyframe
/// a delta frame is read against, and the hand-offs of older frames of its sender it replaced
/// (free-running).
#[derive(Debug, Clone)]
pub(crate) struct HeldReplication {
    pub(crate) from: ClusterId,
    pub(crate) tick: u64,
    bytes: Arc<[u8]>,
    /// For a delta frame, the tick of the keyframe it is read against.
    key_tick: Option<u64>,
    /// That keyframe's bytes, when this cluster holds them.
    key: Option<Arc<[u8]>>,
    carried: Vec<EntityState>,
}

impl HeldReplication {
    /// Checks untrusted `bytes` and keeps a copy of them.
    pub(crate) fn new(bytes: &[u8]) -> Result<Self, WireError> {
        let view = ReplicationView::parse(bytes)?;
        Ok(Self {
            from: view.from(),
            tick: view.tick(),
            bytes: Arc::from(bytes),
            key_tick: view.delta().map(|d| d.key_tick),
            key: None,
            carried: Vec::new(),
        })
    }

    /// For a delta frame, the tick of the keyframe it needs; `None` for a keyframe.
    pub(crate) fn key_tick(&self) -> Option<u64> {
        self.key_tick
    }

    /// The bytes, shared (a keyframe is kept to read the delta frames after it against).
    pub(crate) fn bytes(&self) -> Arc<[u8]> {
        Arc::clone(&self.bytes)
    }

    /// Gives a delta frame the keyframe it is read against.
    pub(crate) fn read_against(&mut self, key: Arc<[u8]>) {
        self.key = Some(key);
    }

    /// Whether the frame stands for every entity its sender owns: a keyframe, or a delta frame
    /// with its keyframe. A delta frame without one (the keyframe was lost) holds only what
    /// changed: an entity it does not mention may still be there.
    pub(crate) fn is_whole(&self) -> bool {
        self.key_tick.is_none() || self.key.is_some()
    }

    /// The frame as records, read in place.
    pub(crate) fn view(&self) -> Option<ReplicationView<'_>> {
        // Checked in `new`; the bytes have not changed since.
        ReplicationView::parse(&self.bytes).ok()
    }

    /// The keyframe's states this delta frame marks unchanged, by index: `(keyframe, index)`.
    fn unchanged(&self) -> Option<(ReplicationView<'_>, impl Iterator<Item = usize> + '_)> {
        let delta = self.view()?.delta()?;
        let key = ReplicationView::parse(self.key.as_deref()?).ok()?;
        let listed = key.len().min(delta.key_states as usize);
        Some((key, (0..listed).filter(move |&j| delta.is_unchanged(j))))
    }

    /// Every state the frame holds (for a delta frame read against its keyframe, the states it
    /// lists, then the keyframe's unchanged ones as of this frame's tick), then the hand-offs
    /// it carries; a record that does not read is an error in its place.
    pub(crate) fn states(&self) -> impl Iterator<Item = Result<EntityState, WireError>> + '_ {
        let view = self.view();
        let listed = view.map_or(0, |v| v.len());
        let tick = self.tick;
        let unchanged = self.unchanged().into_iter().flat_map(move |(key, js)| {
            js.map(move |j| key.state(j).map(|state| EntityState { tick, ..state }))
        });
        (0..listed)
            .filter_map(move |i| view.map(|v| v.state(i)))
            .chain(unchanged)
            .chain(self.carried.iter().copied().map(Ok))
    }

    /// The entities the frame mentions, carried hand-offs included.
    pub(crate) fn ids(&self) -> impl Iterator<Item = EntityId> + '_ {
        let view = self.view();
        let listed = view.map_or(0, |v| v.len());
        let unchanged = self
            .unchanged()
            .into_iter()
            .flat_map(|(key, js)| js.filter_map(move |j| key.id(j)));
        (0..listed)
            .filter_map(move |i| view.and_then(|v| v.id(i)))
            .chain(unchanged)
            .chain(self.carried.iter().map(|s| s.id))
    }

    /// Fills a frame that is not whole with the states of `older` (its sender's picture before
    /// it) that it does not mention: what adoption would take if the sender died now.
    pub(crate) fn fill_from(&mut self, older: &HeldReplication) {
        let mentioned: IdMap<EntityId, ()> = self.ids().map(|id| (id, ())).collect();
        let missing: Vec<EntityState> = older
            .states()
            .filter_map(Result::ok)
            .filter(|s| !mentioned.contains_key(&s.id))
            .collect();
        self.carried.extend(missing);
    }
}

/// Frames waiting to be used.
#[derive(Default)]
pub(crate) struct Inbox {
    replication: BTreeMap<(u64, ClusterId), HeldReplication>,
    /// With the host monotonic time it was received at.
    events: BTreeMap<(u64, ClusterId), (PhysicsEventsFrame, u64)>,
}

/// The frames one tick uses, in neighbour order.
pub(crate) struct TickFrames {
    pub(crate) replication: Vec<HeldReplication>,
    /// With the time each was received at.
    pub(crate) events: Vec<(PhysicsEventsFrame, u64)>,
}

impl Inbox {
    /// Keeps a replication frame, unless one of the same tick and sender is already kept (a
    /// sender publishes one per tick: a second is a replay or a forgery, and the first stays).
    /// Returns whether it was kept.
    pub(crate) fn add_replication(&mut self, frame: HeldReplication) -> bool {
        match self.replication.entry((frame.tick, frame.from)) {
            Entry::Vacant(slot) => {
                slot.insert(frame);
                true
            }
            Entry::Occupied(_) => false,
        }
    }

    /// Keeps a replication frame in place of any other of the same sender (free-running): of
    /// the two, the newer stays, carrying the hand-offs of the older (see [`Self::take_all`]).
    /// However long a backlog (a pod resuming after a stall reads everything Redis kept for
    /// it), the inbox holds one replication frame per sender. Returns whether it was kept (a
    /// frame of a tick already kept is not).
    pub(crate) fn add_replication_newest(&mut self, frame: HeldReplication) -> bool {
        if self.replication.contains_key(&(frame.tick, frame.from)) {
            return false;
        }
        let from = frame.from;
        let kept: Vec<(u64, ClusterId)> = self
            .replication
            .keys()
            .filter(|(_, sender)| *sender == from)
            .copied()
            .collect();
        let mut newest = frame;
        for key in kept {
            if let Some(mut other) = self.replication.remove(&key) {
                if other.tick > newest.tick {
                    std::mem::swap(&mut other, &mut newest);
                }
                carry_handoffs(other, &mut newest);
            }
        }
        self.replication.insert((newest.tick, from), newest);
        true
    }

    /// Keeps an events frame received at `received_ns`, the first of each sender and tick as
    /// for replication. Returns whether it was kept.
    pub(crate) fn add_events(&mut self, frame: PhysicsEventsFrame, received_ns: u64) -> bool {
        match self.events.entry((frame.tick, frame.from)) {
            Entry::Vacant(slot) => {
                slot.insert((frame, received_ns));
                true
            }
            Entry::Occupied(_) => false,
        }
    }

    /// The first of `neighbours` whose frame tagged `tick` is missing, and which kind.
    pub(crate) fn missing(
        &self,
        tick: u64,
        neighbours: &[ClusterId],
        replication_expected: bool,
    ) -> Option<(ClusterId, &'static str)> {
        neighbours.iter().find_map(|&n| {
            if replication_expected && !self.replication.contains_key(&(tick, n)) {
                Some((n, "replication"))
            } else if !self.events.contains_key(&(tick, n)) {
                Some((n, "physics_events"))
            } else {
                None
            }
        })
    }

    /// Takes the frames tagged `tick` (lock-step), in `neighbours` order, and drops older ones.
    pub(crate) fn take_tick(&mut self, tick: u64, neighbours: &[ClusterId]) -> TickFrames {
        let frames = TickFrames {
            replication: neighbours
                .iter()
                .filter_map(|&n| self.replication.remove(&(tick, n)))
                .collect(),
            events: neighbours
                .iter()
                .filter_map(|&n| self.events.remove(&(tick, n)))
                .collect(),
        };
        self.replication.retain(|(t, _), _| *t > tick);
        self.events.retain(|(t, _), _| *t > tick);
        frames
    }

    /// Takes everything (free-running): every events frame, and the newest replication frame of
    /// each sender. A hand-off in an older frame the newest one no longer lists rides along in
    /// the newest (the old owner stops listing an entity right after handing it over, so
    /// skipping that frame would lose the entity).
    pub(crate) fn take_all(&mut self) -> TickFrames {
        let mut newest: BTreeMap<ClusterId, HeldReplication> = BTreeMap::new();
        // Keys sort by tick first, so each sender's frames come oldest first.
        for ((_, from), frame) in std::mem::take(&mut self.replication) {
            let Some(older) = newest.insert(from, frame) else {
                continue;
            };
            if let Some(newer) = newest.get_mut(&from) {
                carry_handoffs(older, newer);
            }
        }
        TickFrames {
            replication: newest.into_values().collect(),
            events: std::mem::take(&mut self.events).into_values().collect(),
        }
    }
}

/// Moves the hand-offs of `older` that `newer` does not list into `newer`: the old owner stops
/// listing an entity once it has handed it over, so dropping that frame would lose the entity.
fn carry_handoffs(older: HeldReplication, newer: &mut HeldReplication) {
    let mut handoffs: Vec<EntityState> = Vec::new();
    if let Some(view) = older.view() {
        handoffs.extend(
            (0..view.len())
                .filter(|&i| view.hands_off(i))
                .filter_map(|i| view.state(i).ok()),
        );
    }
    handoffs.extend(older.carried);
    for state in handoffs {
        if !newer.ids().any(|id| id == state.id) {
            newer.carried.push(state);
        }
    }
}

#[cfg(test)]
mod tests {
    use seam_sim::wire::{BodySpec, ReplicationFrame, Shape, StateEncoding};

    use super::*;

    fn held(from: ClusterId, tick: u64, states: Vec<EntityState>) -> HeldReplication {
        let frame = ReplicationFrame { from, tick, states };
        let bytes = frame.encode(StateEncoding::Exact).expect("encodes");
        HeldReplication::new(&bytes).expect("decodes")
    }

    fn states(frame: &HeldReplication) -> Vec<EntityState> {
        frame.states().map(|s| s.expect("reads")).collect()
    }

    fn state(id: EntityId, owner: ClusterId, x: f32) -> EntityState {
        let body = BodySpec::new(Shape::ball(0.5)).density(1.0);
        EntityState::new(id, owner, body).at([x, 0.0, 0.0])
    }

    #[test]
    fn free_running_keeps_one_frame_per_sender_with_its_handoffs() {
        let (a, b) = (ClusterId::random(), ClusterId::random());
        let (kept, handed) = (EntityId::random(), EntityId::random());
        let mut inbox = Inbox::default();
        assert!(inbox.add_replication_newest(held(
            a,
            7,
            vec![state(kept, a, 1.0), state(handed, b, 2.0)]
        )));
        for tick in 8..100 {
            assert!(inbox.add_replication_newest(held(a, tick, vec![state(kept, a, tick as f32)])));
            assert_eq!(
                inbox.replication.len(),
                1,
                "one frame held, however long the backlog"
            );
        }
        assert!(!inbox.add_replication_newest(held(a, 99, Vec::new())));
        let frames = inbox.take_all();
        let newest = &frames.replication[0];
        assert_eq!(newest.tick, 99);
        let newest = states(newest);
        assert_eq!(newest[0].position[0], 99.0);
        assert_eq!(newest[1].id, handed, "the hand-off rode along");
    }

    #[test]
    fn a_handoff_in_a_skipped_frame_rides_in_the_newest() {
        let (a, b) = (ClusterId::random(), ClusterId::random());
        let (kept, handed) = (EntityId::random(), EntityId::random());
        let mut inbox = Inbox::default();
        inbox.add_replication(held(a, 7, vec![state(kept, a, 1.0), state(handed, b, 2.0)]));
        inbox.add_replication(held(a, 8, vec![state(kept, a, 1.5)]));
        let frames = inbox.take_all();
        assert_eq!(frames.replication.len(), 1);
        let newest = &frames.replication[0];
        assert_eq!(newest.tick, 8);
        let newest = states(newest);
        assert_eq!(newest.len(), 2);
        assert_eq!(newest[0].position[0], 1.5, "the newest pose wins");
        assert_eq!(newest[1].id, handed);
        assert_eq!(newest[1].cluster_id, b);
    }
}
