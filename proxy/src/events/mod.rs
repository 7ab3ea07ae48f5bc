//! Everything that happens in a cluster, once: [`ClusterEvent`], and its consumers.
//!
//! Each part of a cluster emits what it does as one event on one stream ([`Events`]): an op
//! sent, applied or dropped (with its reason), a hand-off given or taken, a contact reported or
//! surfaced, a neighbour lost, left or back, a frame refused. The consumers read that stream and
//! keep nothing of their own making:
//!
//! - [`ClusterStats`] counts every event, always (`Cluster::stats`);
//! - with `Cluster::keep_events`, the events themselves are kept, stamped with the tick, for
//!   the caller to take (`Cluster::take_events`): `seam node` writes its ledger from them
//!   ([`LedgerEntry::from_event`]), times routed ops from [`ClusterEvent::OpApplied`] and
//!   records hand-offs from [`ClusterEvent::HandoffGiven`] and [`ClusterEvent::HandoffTaken`].
//!
//! # Layout
//!
//! - `event` — [`ClusterEvent`] and the reasons it names ([`OpDrop`], [`ContactGiveUp`],
//!   [`FrameRefusal`]); [`Name`], what names an op or a contact report.
//! - `log` — [`Events`]: the stream, the counters and the kept events ([`TickEvent`]).
//! - `stats` — [`ClusterStats`], the counters, and how each event counts.
//! - `ledger` — [`LedgerEntry`]: what became of each name, as one line of text.
//! - `timing` — [`OpTiming`]: the stage times of a routed op.

mod event;
mod ledger;
mod log;
mod stats;
mod timing;

pub use event::{ClusterEvent, ContactGiveUp, FrameRefusal, Name, OpDrop};
pub use ledger::{Carried, LedgerEntry, LedgerEvent, parse_cluster};
pub(crate) use log::Events;
pub use log::{MAX_EVENTS, TickEvent};
pub use stats::ClusterStats;
pub use timing::OpTiming;
