//! Settling contacts across the seam, so momentum is conserved.
//!
//! With contacts coupled (`seam_sim::coupling`) each world solves a contact across the seam
//! itself and keeps its own body's impulse: `J_a` in the world that owns `a`, `J_b` in the
//! world that owns `b`. One world would give `J_a = −J_b`. Two worlds agree while they see the
//! same bodies, but a pile-up wider than what each models (its spread) is solved by each side
//! with the other side's bodies beyond that missing, so `J_a + J_b ≠ 0` and momentum is made
//! from nothing, a little every step the pile-up lasts (measured on `grid`, no blasts, 1 200
//! ticks: total momentum 600 kg·m/s off one world's at the end).
//!
//! > Each side reports what the contact gave its body. When a side holds both worlds' impulses
//! > of one pair and step, and they are **one contact** — close, `|J_a + J_b| ≤ ½ (|J_a| +
//! > |J_b|)`, or both felt and opposed, `−J_a·J_b > ½ |J_a| |J_b|` (less than 60° apart, any
//! > sizes) — each side gives its body **−(J_a + J_b) / 2**, so `a` ends with `(J_a − J_b) / 2`
//! > and `b` with `(J_b − J_a) / 2`: equal and opposite.
//!
//! Where the two agree exactly nothing changes. Opposed halves of different sizes are the
//! pile-up above: each world pressed the pair with the bodies it had (measured on `grid`, 1 200
//! ticks, Fixed proxies: momentum error 0.0047–0.0060 of Σm|v| over four runs when only close
//! halves were shared, 0.0028–0.0033 with opposed ones too; without the blasts 0.0016–0.0027
//! against 0.0007–0.0012). A pair only one world felt — the other met it a hair apart, with
//! nothing — is left as each world solved it: one world met a proxy set down into its body at
//! a frame, or a push that reached one side a tick before the other, and sharing such a kick
//! would hand half of an impulse that never happened to a body in the other world (measured on
//! `seam-stack`, the blast's tick: 4.6 → 5.9 cm RMS at a frame every tick, 6.4 → 45 cm at every
//! 2; taking the smaller of the two instead, 5.6 cm at every tick). Both sides decide from the
//! same two numbers, so they decide alike.
//!
//! > A half whose other half does not come within [`HALF_WAITS_TICKS`], of a pair the other
//! > world did not report at any step near it, is a contact the other world did not see: a
//! > shot fired and landed before its owner's next frame reached the target's world. Its
//! > impulse, reversed, goes to the other body's owner as a routed push — the momentum one
//! > world would have given it.
//!
//! Free-running, the two worlds can meet one contact a step apart; both halves then go
//! unmatched by step, and passing both on doubled the push (measured: `light-on-heavy` as
//! free-running pods on shm, 0.55 → 17.8 m RMS), so a pair the other world reported within
//! the wait is taken as seen.
//!
//! (Measured on `light-on-heavy` with a frame every 4 ticks: a 200 m/s shot fired 10 m from
//! its target lands within 3 ticks, before the target's world has a proxy of it; without the
//! push the 100 kg target never moved, 1.49 m RMS.)

use std::collections::BTreeMap;

use seam_sim::SeamImpulse;
use seam_sim::wire::{EntityId, SeamImpulseReport};

/// Free-running, how long one world's impulse of a pair waits for the other's (a frame or two
/// of stagger can delay it), ticks. In lock-step both are there the tick after the step.
pub const HALF_WAITS_TICKS: u64 = 3;

/// One side of a pair: (step, this cluster's body, the other world's body).
type Key = (u64, EntityId, EntityId);

/// A half given up: its key and impulse.
pub(crate) type GivenUp = (u64, EntityId, EntityId, [f32; 3]);

/// Impulses waiting for the other world's of the same pair and step.
#[derive(Default)]
pub(crate) struct Settlement {
    own: BTreeMap<Key, [f32; 3]>,
    theirs: BTreeMap<Key, [f32; 3]>,
    /// Pairs (this cluster's body, the other world's body) the other world reported lately,
    /// with the step of its latest report: free-running, the two worlds can meet one contact a
    /// step apart, and a contact the other world saw at all is not one it missed.
    reported: BTreeMap<(EntityId, EntityId), u64>,
}

fn length(v: [f32; 3]) -> f32 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// What settling gives this cluster's body for one pair, if the two impulses are one contact:
/// close in size and direction, or both felt and pushing the bodies apart along lines less
/// than 60° from each other.
fn settled(mine: [f32; 3], theirs: [f32; 3]) -> Option<[f32; 3]> {
    let disagreement = add(mine, theirs);
    let close = length(disagreement) <= 0.5 * (length(mine) + length(theirs));
    let opposed = -dot(mine, theirs) > 0.5 * length(mine) * length(theirs);
    (close || opposed).then(|| disagreement.map(|c| -0.5 * c))
}

/// What one settling pass did.
#[derive(Debug, Default)]
pub(crate) struct Settled {
    /// Impulses for both bodies of each pair settled, summed by body. The caller gives them
    /// to the bodies it simulates: this cluster's, and the other world's body only if it was
    /// handed here since the step (its old owner, simulating it no more, drops the report
    /// naming it, so its half of the correction is this cluster's to give).
    pub(crate) impulses: BTreeMap<EntityId, [f32; 3]>,
    /// Pairs whose two impulses disagree: left as each world solved them.
    pub(crate) disagreed: u64,
    /// Halves whose other half did not come in time.
    pub(crate) unmatched: u64,
    /// This world's halves among those that gave its body an impulse, as (step, this
    /// cluster's body, the other world's body, the impulse): contacts the other world did not
    /// report — did not see, if its reports of that step have come (the caller knows).
    pub(crate) unanswered: Vec<GivenUp>,
}

impl Settlement {
    /// Notes what this world's step `tick` gave its bodies at the seam.
    pub(crate) fn record(&mut self, tick: u64, impulses: &[SeamImpulse]) {
        for i in impulses {
            self.own.insert((tick, i.own, i.proxy), i.impulse);
        }
    }

    /// Notes that the other world saw `report`'s pair at its step, without settling it (its
    /// body here was handed on since).
    pub(crate) fn seen(&mut self, report: &SeamImpulseReport) {
        let latest = self.reported.entry((report.other, report.own)).or_default();
        *latest = (*latest).max(report.tick);
    }

    /// Matches the reports `received` with this world's impulses and settles the pairs that
    /// have both halves; halves older than `wait` ticks at `now` are given up
    /// ([`HALF_WAITS_TICKS`] free-running, 0 in lock-step).
    pub(crate) fn settle(
        &mut self,
        received: impl IntoIterator<Item = SeamImpulseReport>,
        now: u64,
        wait: u64,
    ) -> Settled {
        for report in received {
            // The report's `other` is this world's body; its `own` the other world's.
            self.theirs
                .insert((report.tick, report.other, report.own), report.impulse);
            self.seen(&report);
        }
        let mut out = Settled::default();
        let both: Vec<Key> = self
            .own
            .keys()
            .filter(|key| self.theirs.contains_key(key))
            .copied()
            .collect();
        for key in both {
            let (Some(mine), Some(theirs)) = (self.own.remove(&key), self.theirs.remove(&key))
            else {
                continue;
            };
            match settled(mine, theirs) {
                Some(impulse) => {
                    for body in [key.1, key.2] {
                        let slot = out.impulses.entry(body).or_insert([0.0; 3]);
                        *slot = add(*slot, impulse);
                    }
                }
                None => out.disagreed += 1,
            }
        }
        let before = self.own.len() + self.theirs.len();
        let fresh = |key: &Key| now.saturating_sub(key.0) < wait;
        let unanswered = &mut out.unanswered;
        let reported = &self.reported;
        self.own.retain(|key, impulse| {
            fresh(key) || {
                // A touch that gave nothing (a resting contact the other world found a hair
                // apart) has no push to pass on; a pair the other world reported within the
                // wait of this step, it saw.
                let seen = reported
                    .get(&(key.1, key.2))
                    .is_some_and(|&at| at.abs_diff(key.0) <= wait.max(1) + 1);
                if length(*impulse) > 0.0 && !seen {
                    unanswered.push((key.0, key.1, key.2, *impulse));
                }
                false
            }
        });
        self.theirs.retain(|key, _| fresh(key));
        let horizon = now.saturating_sub(2 * wait.max(1) + 2);
        self.reported.retain(|_, at| *at >= horizon);
        out.unmatched = (before - self.own.len() - self.theirs.len()) as u64;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(n: u128) -> EntityId {
        EntityId::from_u128(n)
    }

    fn mine(tick: u64, impulse: [f32; 3]) -> (u64, [SeamImpulse; 1]) {
        (
            tick,
            [SeamImpulse {
                own: id(1),
                proxy: id(2),
                impulse,
            }],
        )
    }

    fn theirs(tick: u64, impulse: [f32; 3]) -> SeamImpulseReport {
        SeamImpulseReport {
            own: id(2),
            other: id(1),
            impulse,
            tick,
        }
    }

    #[test]
    fn two_worlds_that_see_one_contact_differently_end_equal_and_opposite() {
        // a (here) got +4 from b; b's world gave b −3 from a.
        let mut here = Settlement::default();
        let (tick, impulses) = mine(7, [4.0, 0.0, 0.0]);
        here.record(tick, &impulses);
        let out = here.settle([theirs(7, [-3.0, 0.0, 0.0])], 7, 0);
        // a: 4 − 0.5 = 3.5 = (J_a − J_b) / 2.
        assert_eq!(out.impulses[&id(1)], [-0.5, -0.0, -0.0]);
        // The other world's body gets the same correction: it is given only by a cluster that
        // simulates it, which is this one once it is handed here after the step.
        assert_eq!(out.impulses[&id(1)], out.impulses[&id(2)]);
        assert!(here.own.is_empty() && here.theirs.is_empty());
    }

    #[test]
    fn a_pile_up_pressed_harder_in_one_world_is_shared() {
        // a got +0.5 where b's world, with more bodies behind b, pressed b with −10.
        let mut here = Settlement::default();
        let (tick, impulses) = mine(3, [0.5, 0.0, 0.0]);
        here.record(tick, &impulses);
        let out = here.settle([theirs(3, [-10.0, 0.1, 0.0])], 3, 0);
        assert_eq!(out.impulses[&id(1)], [4.75, -0.05, -0.0]);
        assert_eq!(out.disagreed, 0);
    }

    #[test]
    fn a_report_before_the_step_waits_for_it_free_running() {
        let mut here = Settlement::default();
        let out = here.settle([theirs(9, [-2.0, 0.0, 0.0])], 8, HALF_WAITS_TICKS);
        assert!(out.impulses.is_empty());
        let (tick, impulses) = mine(9, [2.5, 0.0, 0.0]);
        here.record(tick, &impulses);
        let out = here.settle([], 9, HALF_WAITS_TICKS);
        assert_eq!(out.impulses[&id(1)], [-0.25, -0.0, -0.0]);
    }

    #[test]
    fn disagreeing_and_unmatched_halves_change_nothing() {
        let mut here = Settlement::default();
        // A kick one world felt and the other met with nothing: not the same contact.
        let (tick, impulses) = mine(3, [0.5, 0.0, 0.0]);
        here.record(tick, &impulses);
        let out = here.settle([theirs(3, [0.0, 0.0, 0.0])], 3, 0);
        assert!(out.impulses.is_empty());
        assert_eq!(out.disagreed, 1);
        // Both felt, pushing the same way: not one contact either.
        let (tick, impulses) = mine(4, [0.5, 0.0, 0.0]);
        here.record(tick, &impulses);
        let out = here.settle([theirs(4, [10.0, 0.0, 0.0])], 4, 0);
        assert!(out.impulses.is_empty());
        assert_eq!(out.disagreed, 1);
        // A contact the other world never reports.
        let (tick, impulses) = mine(10, [1.0, 0.0, 0.0]);
        here.record(tick, &impulses);
        let out = here.settle([], 10, 0);
        assert!(out.impulses.is_empty());
        assert_eq!(out.unmatched, 1);
        assert_eq!(out.unanswered, vec![(10, id(1), id(2), [1.0, 0.0, 0.0])]);
    }

    #[test]
    fn a_report_about_a_body_handed_on_since_still_says_the_contact_was_seen() {
        // This world's half of step 7; the other world's half names a body this world has
        // handed on since, so it is only noted as seen: nothing settled, nothing passed on.
        let mut here = Settlement::default();
        let (tick, impulses) = mine(7, [0.0, 380.0, 0.0]);
        here.record(tick, &impulses);
        here.seen(&theirs(7, [0.0, -380.0, 0.0]));
        let out = here.settle([], 7, 0);
        assert!(out.impulses.is_empty());
        assert!(out.unanswered.is_empty(), "{:?}", out.unanswered);
        // Without the note, the same half is a contact the other world missed.
        let mut alone = Settlement::default();
        alone.record(tick, &impulses);
        assert_eq!(alone.settle([], 7, 0).unanswered.len(), 1);
    }

    #[test]
    fn a_contact_the_other_world_met_a_step_apart_is_not_passed_on() {
        // Free-running: the other world met the pair at step 20, this one at 21.
        let mut here = Settlement::default();
        let out = here.settle([theirs(20, [-1.0, 0.0, 0.0])], 20, HALF_WAITS_TICKS);
        assert!(out.unanswered.is_empty());
        let (tick, impulses) = mine(21, [1.0, 0.0, 0.0]);
        here.record(tick, &impulses);
        let out = here.settle([], 21 + HALF_WAITS_TICKS, HALF_WAITS_TICKS);
        assert_eq!(out.unmatched, 2, "neither half matched by step");
        assert!(out.unanswered.is_empty(), "but the other world saw it");
    }
}
