//! Each contact once per side.
//!
//! A contact across the seam can be seen twice by one cluster: in its own world (its body
//! against its proxy of the neighbour's, or its proxy of the neighbour's body against its own)
//! and in the neighbour's report of the same pair. Which comes first depends on who saw it
//! first; a world may also not see it at all (a proxy of a body its owner moves itself meets
//! nothing here that produces an event). So neither copy is thrown away blindly:
//!
//! > A contact (the pair and whether it started or stopped) surfaces the first time it is seen,
//! > locally or in a report; the same contact from the *other* source within
//! > [`MERGE_WINDOW_TICKS`] is the same event and is dropped (counted in
//! > `ClusterStats::contacts_merged`).

use std::collections::HashMap;

use seam_sim::ContactEvent;
use seam_sim::wire::EntityId;

/// How many ticks apart the two copies of one contact may surface: a report takes a frame to
/// arrive, and the two worlds may see the contact a step or two apart.
pub const MERGE_WINDOW_TICKS: u64 = 8;

/// The pair (in id order) and whether the contact started.
type Key = (EntityId, EntityId, bool);

fn key(contact: &ContactEvent) -> Key {
    (
        contact.a.min(contact.b),
        contact.a.max(contact.b),
        contact.started,
    )
}

/// Contacts surfaced lately: when, and whether seen locally.
#[derive(Default)]
pub(crate) struct ContactMerge {
    recent: HashMap<Key, (u64, bool)>,
}

impl ContactMerge {
    /// Forgets contacts surfaced more than the window before `tick`.
    pub(crate) fn expire(&mut self, tick: u64) {
        self.recent
            .retain(|_, (at, _)| tick.saturating_sub(*at) <= MERGE_WINDOW_TICKS);
    }

    /// Whether `contact`, seen at `tick` (`local`: in this world; else reported), is new:
    /// not already surfaced from the other source within the window. A new one is remembered.
    pub(crate) fn is_new(&mut self, contact: &ContactEvent, tick: u64, local: bool) -> bool {
        let key = key(contact);
        match self.recent.get(&key) {
            Some(&(at, seen_locally))
                if seen_locally != local && tick.saturating_sub(at) <= MERGE_WINDOW_TICKS =>
            {
                false
            }
            _ => {
                self.recent.insert(key, (tick, local));
                true
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contact(a: u128, b: u128, started: bool) -> ContactEvent {
        ContactEvent {
            a: EntityId::from_u128(a),
            b: EntityId::from_u128(b),
            started,
            impulse: [0.0; 3],
            normal: [0.0; 3],
            reported_by: None,
        }
    }

    #[test]
    fn the_second_copy_from_the_other_source_is_dropped_whichever_comes_first() {
        let mut merge = ContactMerge::default();
        assert!(merge.is_new(&contact(1, 2, true), 10, true));
        // The neighbour's report of the same start, a tick later, pair the other way round.
        assert!(!merge.is_new(&contact(2, 1, true), 11, false));
        // Reported first, seen here later.
        assert!(merge.is_new(&contact(3, 4, true), 10, false));
        assert!(!merge.is_new(&contact(3, 4, true), 12, true));
        // A stop is another event.
        assert!(merge.is_new(&contact(1, 2, false), 20, true));
    }

    #[test]
    fn copies_from_one_source_and_copies_outside_the_window_both_surface() {
        let mut merge = ContactMerge::default();
        assert!(merge.is_new(&contact(1, 2, true), 10, true));
        // The same world sees it start again (it bounced): a new contact.
        assert!(merge.is_new(&contact(1, 2, true), 14, true));
        // A report long after is another contact too.
        merge.expire(14 + MERGE_WINDOW_TICKS + 1);
        assert!(merge.is_new(&contact(1, 2, true), 14 + MERGE_WINDOW_TICKS + 1, false));
    }
}
