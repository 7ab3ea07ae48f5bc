//! At least once, applied once: how routed ops and contact reports travel.
//!
//! Every op and every contact report is named by its issuer and a number from the issuer's
//! one counter ([`Numbers`], a [`Name`](crate::events::Name)). The sender keeps each item it
//! sends until the receiver answers it ([`Outbound`]) and sends it again every
//! `op_retry_ticks` to where it then belongs; the receiver closes each name once and answers
//! every copy ([`Receipts`]). One mechanism carries both kinds: only where an item goes next
//! differs, and a [`Courier`] says that.
//!
//! # Layout
//!
//! - `outbound` — [`Outbound`]: the items queued for this tick's frames and those unanswered;
//!   resends, through a [`Courier`].
//! - `outstanding` — the unanswered items by name, bounded per destination.
//! - `receipts` — [`Receipts`]: the names closed per issuer, and the answers to send.
//! - `window` — one issuer's closed numbers.

mod outbound;
mod outstanding;
mod receipts;
mod window;

pub(crate) use outbound::{Courier, Outbound, Resend, Route};
pub(crate) use outstanding::Unanswered;
pub(crate) use receipts::Receipts;
pub(crate) use window::Verdict;

/// The numbers this cluster gives the ops it issues and the contacts it reports.
#[derive(Debug)]
pub(crate) struct Numbers {
    next: u64,
}

impl Numbers {
    /// Numbers from the wall clock's microseconds now, so a pod restarted under the same id
    /// numbers its ops past those of its earlier life (owners would otherwise take its new ops
    /// for repeats of old ones).
    pub(crate) fn from_clock() -> Self {
        let next = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(1, |d| d.as_micros() as u64);
        Self { next }
    }

    /// The next number.
    pub(crate) fn take(&mut self) -> u64 {
        let seq = self.next;
        self.next += 1;
        seq
    }
}

/// When unanswered items are sent again, and when they are given up.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Retry {
    /// Ticks between two sends of an unanswered item.
    pub(crate) every: u64,
    /// The age from which an unanswered item is given up. Past its age limit any receiver
    /// drops it as stale — unless it closed it already (its answer lost, say to an outage):
    /// so it is still sent, to be answered either way, for as long as a receiver may stay
    /// silent and still be alive.
    pub(crate) give_up_at: u64,
}

impl Retry {
    /// Sent again every `retry_ticks`; given up past `max_age_ticks` and twice
    /// `timeout_ticks` (the silence after which a neighbour is taken for dead).
    pub(crate) fn new(retry_ticks: u64, max_age_ticks: u64, timeout_ticks: u64) -> Self {
        Self {
            every: retry_ticks.max(1),
            give_up_at: max_age_ticks + timeout_ticks.max(1) * 2,
        }
    }
}
