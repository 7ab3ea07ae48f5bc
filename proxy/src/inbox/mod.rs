//! Frames in: decoded from the bytes received, and kept, by sender and tick, until the tick
//! that uses them.
//!
//! A frame is tagged with the number of steps its sender had taken when it published. In
//! lock-step a cluster that has taken `n` steps uses exactly the frames tagged `n` and keeps
//! later ones for later ticks, so what it sees does not depend on how fast a transport
//! delivered: the same run gives the same result on every transport.
//!
//! # Layout
//!
//! - `decode` — a received message made a frame, or told why not.
//! - `held` — [`HeldReplication`]: a replication frame read in place.
//! - here: [`Inbox`], the frames waiting, and [`TickFrames`], those one tick uses.

use std::collections::BTreeMap;
use std::collections::btree_map::Entry;

use seam_sim::wire::{ClusterId, PhysicsEventsFrame, Stage};

mod decode;
mod held;

pub(crate) use decode::{Frame, FrameKind, Refused, decode_frame};
pub(crate) use held::HeldReplication;

/// Frames waiting to be used.
#[derive(Default)]
pub(crate) struct Inbox {
    replication: BTreeMap<(u64, ClusterId), HeldReplication>,
    /// With the host monotonic time it was received at.
    events: BTreeMap<(u64, ClusterId), (PhysicsEventsFrame, u64)>,
    /// Events frames published before their sender's step (the exchange), by the tick they
    /// were published in, with the time received.
    exchange: BTreeMap<(u64, ClusterId), (PhysicsEventsFrame, u64)>,
}

/// The frames one tick uses, in neighbour order.
#[derive(Default)]
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

    /// Keeps a replication frame in place of all but the newest other of the same sender
    /// (free-running): the two newest stay, the older carrying the hand-offs of every frame
    /// before it (see [`Self::take_all`]), so a tick can take its neighbour's frame of its own
    /// tick while the next one, already in, waits for the next tick. However long a backlog (a
    /// pod resuming after a stall reads everything Redis kept for it), the inbox holds two
    /// replication frames per sender. Returns whether it was kept (a frame of a tick already
    /// kept is not).
    pub(crate) fn add_replication_newest(&mut self, frame: HeldReplication) -> bool {
        if self.replication.contains_key(&(frame.tick, frame.from)) {
            return false;
        }
        let from = frame.from;
        self.replication.insert((frame.tick, from), frame);
        // Keys sort by tick first: this sender's frames, oldest first.
        let mut kept: Vec<(u64, ClusterId)> = self
            .replication
            .keys()
            .filter(|(_, sender)| *sender == from)
            .copied()
            .collect();
        while kept.len() > 2 {
            let oldest = kept.remove(0);
            let Some(old) = self.replication.remove(&oldest) else {
                continue;
            };
            if let Some(next) = self.replication.get_mut(&kept[0]) {
                next.carry_handoffs_of(old);
            }
        }
        true
    }

    /// Keeps an events frame received at `received_ns`, the first of each sender, stage and
    /// tick as for replication. Returns whether it was kept.
    pub(crate) fn add_events(&mut self, frame: PhysicsEventsFrame, received_ns: u64) -> bool {
        let kept = if frame.stage == Stage::BeforeStep {
            &mut self.exchange
        } else {
            &mut self.events
        };
        match kept.entry((frame.tick, frame.from)) {
            Entry::Vacant(slot) => {
                slot.insert((frame, received_ns));
                true
            }
            Entry::Occupied(_) => false,
        }
    }

    /// Drops every frame of `sender` held (sent by a pod a newer one replaced).
    pub(crate) fn forget(&mut self, sender: ClusterId) {
        self.replication.retain(|(_, from), _| *from != sender);
        self.events.retain(|(_, from), _| *from != sender);
        self.exchange.retain(|(_, from), _| *from != sender);
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

    /// Whether `neighbour`'s exchange frame of `tick` (or a later one) is in.
    pub(crate) fn has_exchange(&self, tick: u64, neighbour: ClusterId) -> bool {
        self.exchange
            .keys()
            .any(|&(t, from)| from == neighbour && t >= tick)
    }

    /// Takes the exchange frames of `tick` and before, in `neighbours` order (each sender's
    /// oldest first); the next tick's stay for it. Free-running, those further ahead are taken
    /// too: this cluster is behind its neighbour (stalled, catching up) or counts its ticks
    /// from another start, and holding them would hold their ops for as long.
    pub(crate) fn take_exchange(
        &mut self,
        tick: u64,
        neighbours: &[ClusterId],
        free_running: bool,
    ) -> Vec<(PhysicsEventsFrame, u64)> {
        let due = |t: u64| t <= tick || (free_running && t > tick + 1);
        let mut taken = Vec::new();
        for &n in neighbours {
            let keys: Vec<(u64, ClusterId)> = self
                .exchange
                .keys()
                .filter(|&&(t, from)| from == n && due(t))
                .copied()
                .collect();
            taken.extend(keys.iter().filter_map(|key| self.exchange.remove(key)));
        }
        taken
    }

    /// Takes everything (free-running) for the tick `tick`: every events frame, and the newest
    /// replication frame of each sender, except one of the next tick (`tick + 1`, a neighbour
    /// a step ahead), which waits for that tick while an older one is there to take: a proxy
    /// stands where its entity is at this tick, as in lock-step, not a step on. A hand-off in
    /// an older frame the newest one no longer lists rides along in the newest (the old owner
    /// stops listing an entity right after handing it over, so skipping that frame would lose
    /// the entity).
    pub(crate) fn take_all(&mut self, tick: u64) -> TickFrames {
        let mut newest: BTreeMap<ClusterId, HeldReplication> = BTreeMap::new();
        let mut held = BTreeMap::new();
        // Keys sort by tick first, so each sender's frames come oldest first.
        for ((t, from), frame) in std::mem::take(&mut self.replication) {
            if t == tick + 1 && newest.contains_key(&from) {
                held.insert((t, from), frame);
                continue;
            }
            let Some(older) = newest.insert(from, frame) else {
                continue;
            };
            if let Some(newer) = newest.get_mut(&from) {
                newer.carry_handoffs_of(older);
            }
        }
        self.replication = held;
        TickFrames {
            replication: newest.into_values().collect(),
            events: std::mem::take(&mut self.events).into_values().collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use seam_sim::wire::{BodySpec, EntityId, EntityState, ReplicationFrame, Shape, StateEncoding};

    use super::*;

    fn held(from: ClusterId, tick: u64, states: Vec<EntityState>) -> HeldReplication {
        let frame = ReplicationFrame {
            from,
            tick,
            incarnation: 0,
            states,
        };
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
    fn free_running_keeps_two_frames_per_sender_with_their_handoffs() {
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
                2,
                "two frames held, however long the backlog"
            );
        }
        assert!(!inbox.add_replication_newest(held(a, 99, Vec::new())));
        let frames = inbox.take_all(100);
        let newest = &frames.replication[0];
        assert_eq!(newest.tick, 99);
        let newest = states(newest);
        assert_eq!(newest[0].position[0], 99.0);
        assert_eq!(newest[1].id, handed, "the hand-off rode along");
    }

    #[test]
    fn a_frame_of_the_next_tick_waits_for_it() {
        let a = ClusterId::random();
        let kept = EntityId::random();
        let mut inbox = Inbox::default();
        inbox.add_replication_newest(held(a, 7, vec![state(kept, a, 1.0)]));
        inbox.add_replication_newest(held(a, 8, vec![state(kept, a, 2.0)]));
        let frames = inbox.take_all(7);
        assert_eq!(frames.replication.len(), 1);
        assert_eq!(frames.replication[0].tick, 7, "this tick's frame");
        let frames = inbox.take_all(8);
        assert_eq!(
            frames.replication[0].tick, 8,
            "the next one at the next tick"
        );
        // Alone, a frame a step ahead is taken: better than none.
        inbox.add_replication_newest(held(a, 10, vec![state(kept, a, 3.0)]));
        assert_eq!(inbox.take_all(9).replication[0].tick, 10);
    }

    #[test]
    fn a_handoff_in_a_skipped_frame_rides_in_the_newest() {
        let (a, b) = (ClusterId::random(), ClusterId::random());
        let (kept, handed) = (EntityId::random(), EntityId::random());
        let mut inbox = Inbox::default();
        inbox.add_replication(held(a, 7, vec![state(kept, a, 1.0), state(handed, b, 2.0)]));
        inbox.add_replication(held(a, 8, vec![state(kept, a, 1.5)]));
        let frames = inbox.take_all(100);
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
