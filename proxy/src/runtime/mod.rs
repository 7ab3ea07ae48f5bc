//! Running clusters: one per process on the host's clock ([`Schedule`]), or several of one
//! process in lock-step ([`lockstep_round`]).

mod lockstep;
mod schedule;

pub use lockstep::lockstep_round;
pub use schedule::{DRAIN_TICKS_UNSCHEDULED, Due, Schedule};
