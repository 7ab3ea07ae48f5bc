//! Who is alive, and what becomes of the entities of those who are not.
//!
//! # Layout
//!
//! - `liveness` — [`Neighbours`]: each neighbour's status ([`NeighbourStatus`]) from the
//!   frames it sends; the silent taken for dead, the leaving taken as left, frames replayed or
//!   tagged implausibly far ahead told apart.
//! - `custody` — [`Custody`]: each neighbour's last picture, the entities adopted from the
//!   dead by the rule of `crate::authority::adoption`, and their return.

mod custody;
mod liveness;

pub(crate) use custody::Custody;
pub use liveness::NeighbourStatus;
pub(crate) use liveness::{Incarnation, Neighbours};
