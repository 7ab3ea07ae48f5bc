//! Each contact once per side.
//!
//! A contact across the seam can be seen twice by one cluster: in its own world (its body
//! against its proxy of the neighbour's, or its proxy of the neighbour's body against its own)
//! and in the neighbour's report of the same pair. Which comes first depends on who saw it
//! first; a world may also not see it at all (a proxy of a body its owner moves itself meets
//! nothing here that produces an event). So neither copy is thrown away blindly:
//!
//! > A contact (the pair and whether it started or stopped) surfaces the first time it is seen,
//! > locally or in a report; the same contact from the *other* source, happened within
//! > [`MERGE_WINDOW_TICKS`] of it, is the same event and is dropped (counted in
//! > `ClusterStats::contacts_merged`). Each copy meets at most one from the other source.
//!
//! When a contact happened is told on this cluster's clock as a span: a local one at the tick
//! it is surfaced; a reported one between the tick it arrives less the ticks it spent in the
//! reporter's hands (`ContactReport::age_ticks`) and the tick it arrives (this cluster may have
//! stalled meanwhile, its clock standing while the reporter's ran). So a report sent again
//! after a lost frame, or read late after a stall, still meets the local copy it repeats; of
//! several, the one nearest the report's earliest moment. The caller passes only local
//! contacts that can have a twin (with a neighbour's entity).

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

/// One copy of a contact surfaced lately: a sighting.
#[derive(Clone, Copy)]
struct Sighting {
    /// The earliest it may have happened, on this cluster's clock.
    at: u64,
    /// How many ticks after `at` it may have happened.
    span: u64,
    /// Seen in this world (else reported).
    local: bool,
    /// Already met by a copy from the other source.
    met: bool,
}

/// Contacts surfaced lately, by pair: when each happened, and whether it was seen locally.
#[derive(Default)]
pub(crate) struct ContactMerge {
    recent: HashMap<Key, Vec<Sighting>>,
}

impl ContactMerge {
    /// Forgets contacts that happened more than the window before the oldest a report may
    /// still tell of: `max_age` ticks before `tick`.
    pub(crate) fn expire(&mut self, tick: u64, max_age: u64) {
        let horizon = MERGE_WINDOW_TICKS + max_age;
        self.recent.retain(|_, copies| {
            copies.retain(|c| tick.saturating_sub(c.at + c.span) <= horizon);
            !copies.is_empty()
        });
    }

    /// Whether `contact`, happened between `at` and `span` ticks later (`local`: seen in this
    /// world, span 0; else reported), is new: no copy from the other source whose span comes
    /// within the window of this one, and not met already, has surfaced. A new one is
    /// remembered; the nearest such copy, if any, is met.
    pub(crate) fn is_new(
        &mut self,
        contact: &ContactEvent,
        at: u64,
        span: u64,
        local: bool,
    ) -> bool {
        let copies = self.recent.entry(key(contact)).or_default();
        let twin = copies
            .iter_mut()
            .filter(|c| {
                c.local != local
                    && !c.met
                    && c.at <= at + span + MERGE_WINDOW_TICKS
                    && at <= c.at + c.span + MERGE_WINDOW_TICKS
            })
            .min_by_key(|c| c.at.abs_diff(at));
        match twin {
            Some(twin) => {
                twin.met = true;
                false
            }
            None => {
                copies.push(Sighting {
                    at,
                    span,
                    local,
                    met: false,
                });
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
        assert!(merge.is_new(&contact(1, 2, true), 10, 0, true));
        // The neighbour's report of the same start, a tick later, pair the other way round.
        assert!(!merge.is_new(&contact(2, 1, true), 11, 0, false));
        // Reported first, seen here later.
        assert!(merge.is_new(&contact(3, 4, true), 10, 0, false));
        assert!(!merge.is_new(&contact(3, 4, true), 12, 0, true));
        // A stop is another event.
        assert!(merge.is_new(&contact(1, 2, false), 20, 0, true));
    }

    #[test]
    fn copies_from_one_source_and_copies_outside_the_window_both_surface() {
        let mut merge = ContactMerge::default();
        assert!(merge.is_new(&contact(1, 2, true), 10, 0, true));
        // The same world sees it start again (it bounced): a new contact.
        assert!(merge.is_new(&contact(1, 2, true), 14, 0, true));
        // A report of one long after is another contact too.
        merge.expire(14 + MERGE_WINDOW_TICKS + 1, 0);
        assert!(merge.is_new(&contact(1, 2, true), 14 + MERGE_WINDOW_TICKS + 1, 0, false));
    }

    #[test]
    fn a_late_report_meets_the_local_copy_it_repeats() {
        let mut merge = ContactMerge::default();
        assert!(merge.is_new(&contact(1, 2, true), 10, 0, true));
        // Sent again after a lost frame: it arrives at 31, having spent 20 ticks with its
        // reporter, so it happened from 11 on.
        merge.expire(31, 30);
        assert!(!merge.is_new(&contact(1, 2, true), 31 - 20, 20, false));
        // The pair touched again at 25, seen here: a late report of the start at 10 meets the
        // copy at 10, and the report of the start at 25 the one at 25.
        assert!(merge.is_new(&contact(3, 4, true), 10, 0, true));
        assert!(merge.is_new(&contact(3, 4, true), 25, 0, true));
        assert!(!merge.is_new(&contact(3, 4, true), 11, 20, false));
        assert!(!merge.is_new(&contact(3, 4, true), 26, 0, false));
        // A third report meets nothing: both local copies are met.
        assert!(merge.is_new(&contact(3, 4, true), 27, 0, false));
        // Past the horizon it is forgotten.
        merge.expire(31 + MERGE_WINDOW_TICKS + 31, 30);
        assert!(merge.is_new(&contact(1, 2, true), 70, 0, false));
    }

    #[test]
    fn a_report_read_after_a_stall_meets_the_copy_seen_after_it() {
        let mut merge = ContactMerge::default();
        // This cluster stood still while the reporter ran 10 ticks: the report arrives at 20
        // aged 10, and this world sees the contact in its next step, at 21.
        assert!(merge.is_new(&contact(5, 6, true), 10, 10, false));
        assert!(!merge.is_new(&contact(5, 6, true), 21, 0, true));
        // A report aged nothing meets only copies within the window.
        assert!(merge.is_new(&contact(7, 8, true), 10, 0, true));
        assert!(merge.is_new(&contact(7, 8, true), 10 + MERGE_WINDOW_TICKS + 1, 0, false));
    }
}
