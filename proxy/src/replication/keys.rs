//! [`Keys`]: each neighbour's last keyframe, what its delta frames are read against.

use std::sync::Arc;

use seam_sim::wire::{ClusterId, IdMap};

use crate::inbox::HeldReplication;

/// Each neighbour's last keyframe received, with its tick.
#[derive(Debug, Default)]
pub(crate) struct Keys {
    keys: IdMap<ClusterId, (u64, Arc<[u8]>)>,
}

impl Keys {
    /// Forgets `neighbour`'s keyframe: a new pod of it counts its ticks from its own start, so
    /// its first keyframe is older than its predecessor's last and must not be taken for
    /// stale (its delta frames were refused until its ticks passed its predecessor's).
    pub(crate) fn forget(&mut self, neighbour: ClusterId) {
        self.keys.swap_remove(&neighbour);
    }

    /// Keeps `frame` if it is a keyframe newer than the one held, or gives a delta frame the
    /// keyframe it names. Returns `false` for a delta frame whose keyframe is not held.
    pub(crate) fn read(&mut self, frame: &mut HeldReplication) -> bool {
        match frame.key_tick() {
            None => {
                let newer = self
                    .keys
                    .get(&frame.from)
                    .is_none_or(|&(tick, _)| tick <= frame.tick);
                if newer {
                    self.keys.insert(frame.from, (frame.tick, frame.bytes()));
                }
                true
            }
            Some(key_tick) => match self.keys.get(&frame.from) {
                Some((tick, key)) if *tick == key_tick => {
                    frame.read_against(Arc::clone(key));
                    true
                }
                _ => false,
            },
        }
    }
}
