//! Contacts across the seam: reported to the other body's owner and surfaced once on each
//! side, pushed both ways in the step they happen (`seam_sim::coupling`), and settled so the
//! pair ends equal and opposite.
//!
//! # Layout
//!
//! - `reports` — [`Reports`]: contacts between a body of this cluster and a proxy, sent to the
//!   proxy's owner (delivered as routed ops are), and the neighbours' reports surfaced once.
//! - `merge` — each contact surfaced once per side, whether seen here or heard of first.
//! - `seam` — [`SeamImpulses`]: what each world's step gave its body at the seam, exchanged
//!   and settled.
//! - `settle` — the rule that settles two halves of one contact.
//! - `prediction` — [`Predictions`]: a push routed to an owner shown on this world's coupled
//!   proxy in the step it is written.

mod merge;
mod prediction;
mod reports;
mod seam;
mod settle;

pub use merge::MERGE_WINDOW_TICKS;
pub(crate) use prediction::Predictions;
pub(crate) use reports::Reports;
pub(crate) use seam::SeamImpulses;
pub use settle::HALF_WAITS_TICKS;
