//! The receiver's side: the numbers an owner has closed, per issuer ([`Closed`]).
//!
//! A receiver closes each name once: it remembers the last [`WINDOW`] numbers of each
//! issuer, answers a repeat without applying it, and drops (counted) a number older than that,
//! which it can no longer tell from a repeat.

use seam_sim::wire::{ClusterId, IdMap};

use crate::events::Name;

/// Numbers of one issuer an owner remembers: the newest it has seen and the 16 383 before (2 KiB
/// per issuer). An issuer numbers all its ops from one counter, so a repeat is told apart as
/// long as the issuer sends fewer than this many ops within one op's lifetime
/// (`max_op_age_ticks`).
pub(crate) const WINDOW: u64 = 16_384;

/// Issuers an owner remembers numbers of (512 KiB at most); the one heard from least lately is
/// forgotten first, counted.
pub(crate) const MAX_ISSUERS: usize = 256;

/// What an owner makes of an op's number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Not closed here before.
    New,
    /// Closed here before: answer it again, do not apply it.
    Repeat,
    /// Older than the window: it cannot be told from a repeat, so it is dropped.
    TooOld,
}

/// One issuer's window: bit `seq % WINDOW` is set when `seq` (within `WINDOW` of `newest`) has
/// been closed.
#[derive(Debug, Clone)]
struct Window {
    newest: u64,
    bits: [u64; (WINDOW / 64) as usize],
    touched: u64,
}

impl Window {
    fn new(seq: u64, touched: u64) -> Self {
        Self {
            newest: seq,
            bits: [0; (WINDOW / 64) as usize],
            touched,
        }
    }

    fn bit(seq: u64) -> (usize, u64) {
        let at = seq % WINDOW;
        ((at / 64) as usize, 1 << (at % 64))
    }

    fn verdict(&self, seq: u64) -> Verdict {
        if seq > self.newest {
            return Verdict::New;
        }
        if self.newest - seq >= WINDOW {
            return Verdict::TooOld;
        }
        let (word, mask) = Self::bit(seq);
        if self.bits[word] & mask != 0 {
            Verdict::Repeat
        } else {
            Verdict::New
        }
    }

    fn close(&mut self, seq: u64) {
        if seq > self.newest {
            // Slide: the numbers passed over have not been seen.
            let gap = seq - self.newest;
            if gap >= WINDOW {
                self.bits = [0; (WINDOW / 64) as usize];
            } else {
                for passed in self.newest + 1..=seq {
                    let (word, mask) = Self::bit(passed);
                    self.bits[word] &= !mask;
                }
            }
            self.newest = seq;
        }
        let (word, mask) = Self::bit(seq);
        self.bits[word] |= mask;
    }
}

/// The op numbers this cluster has closed, per issuer.
#[derive(Debug, Default)]
pub(crate) struct Closed {
    windows: IdMap<ClusterId, Window>,
    /// Counts closings, to tell which window was touched least lately.
    clock: u64,
    /// Windows forgotten to make room.
    pub(crate) forgotten: u64,
}

impl Closed {
    /// What `key` is here.
    pub(crate) fn verdict(&self, key: Name) -> Verdict {
        self.windows
            .get(&key.issuer)
            .map_or(Verdict::New, |w| w.verdict(key.seq))
    }

    /// Marks `key` closed: applied, dropped for good, or taken on to forward.
    pub(crate) fn close(&mut self, key: Name) {
        self.clock += 1;
        let clock = self.clock;
        if !self.windows.contains_key(&key.issuer) && self.windows.len() >= MAX_ISSUERS {
            let stalest = self
                .windows
                .iter()
                .min_by_key(|(_, w)| w.touched)
                .map(|(&id, _)| id);
            if let Some(stalest) = stalest {
                self.windows.swap_remove(&stalest);
                self.forgotten += 1;
            }
        }
        let window = self
            .windows
            .entry(key.issuer)
            .or_insert_with(|| Window::new(key.seq, clock));
        window.touched = clock;
        window.close(key.seq);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn issuer() -> ClusterId {
        ClusterId::from_u128(1)
    }

    #[test]
    fn a_number_is_closed_once_and_a_repeat_is_seen() {
        let mut closed = Closed::default();
        let key = Name::new(issuer(), 5_000);
        assert_eq!(closed.verdict(key), Verdict::New);
        closed.close(key);
        assert_eq!(closed.verdict(key), Verdict::Repeat);
        // Numbers around it, older and newer, are still new.
        assert_eq!(closed.verdict(Name::new(issuer(), 4_999)), Verdict::New);
        assert_eq!(closed.verdict(Name::new(issuer(), 5_001)), Verdict::New);
        // Another issuer's same number is another op.
        assert_eq!(
            closed.verdict(Name::new(ClusterId::from_u128(2), 5_000)),
            Verdict::New
        );
    }

    #[test]
    fn the_window_slides_and_what_falls_out_is_too_old_never_new() {
        let mut closed = Closed::default();
        for seq in 0..3 * WINDOW {
            if seq % 3 != 0 {
                closed.close(Name::new(issuer(), seq));
            }
        }
        let newest = 3 * WINDOW - 1;
        for seq in 0..=newest {
            let verdict = closed.verdict(Name::new(issuer(), seq));
            let expected = if newest - seq >= WINDOW {
                Verdict::TooOld
            } else if seq % 3 != 0 {
                Verdict::Repeat
            } else {
                Verdict::New
            };
            assert_eq!(verdict, expected, "seq {seq}");
        }
        // A jump further than the window clears it.
        closed.close(Name::new(issuer(), newest + 10 * WINDOW));
        assert_eq!(closed.verdict(Name::new(issuer(), newest)), Verdict::TooOld);
        assert_eq!(
            closed.verdict(Name::new(issuer(), newest + 10 * WINDOW - 1)),
            Verdict::New
        );
    }

    #[test]
    fn issuers_past_the_limit_forget_the_least_lately_heard() {
        let mut closed = Closed::default();
        for n in 0..MAX_ISSUERS as u128 + 1 {
            closed.close(Name::new(ClusterId::from_u128(n + 10), 1));
        }
        assert_eq!(closed.forgotten, 1);
        assert_eq!(
            closed.verdict(Name::new(ClusterId::from_u128(10), 1)),
            Verdict::New,
            "the first issuer was forgotten"
        );
        assert_eq!(
            closed.verdict(Name::new(ClusterId::from_u128(11), 1)),
            Verdict::Repeat
        );
    }
}
