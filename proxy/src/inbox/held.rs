//! [`HeldReplication`]: a replication frame as received, read in place when it is used.

use std::sync::Arc;

use seam_sim::wire::{ClusterId, EntityId, EntityState, IdMap, ReplicationView, WireError};

/// A replication frame as received: its bytes, whose header and sizes were checked when it
/// arrived and whose states are read in place when it is used (no decode pass), the keyframe
/// a delta frame is read against, and the hand-offs of older frames of its sender it replaced
/// (free-running).
#[derive(Debug, Clone)]
pub(crate) struct HeldReplication {
    pub(crate) from: ClusterId,
    pub(crate) tick: u64,
    pub(crate) incarnation: u64,
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
            incarnation: view.incarnation(),
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

    /// Moves the hand-offs of `older` that this frame does not list into it: the old owner
    /// stops listing an entity once it has handed it over, so dropping that frame would lose
    /// the entity.
    pub(crate) fn carry_handoffs_of(&mut self, older: HeldReplication) {
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
            if !self.ids().any(|id| id == state.id) {
                self.carried.push(state);
            }
        }
    }
}
