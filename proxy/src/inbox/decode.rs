//! A received message made a frame: decoded straight from the received bytes (on shm, the
//! shared-memory sample), or refused with the reason.

use seam_sim::wire::{self, ClusterId, PhysicsEventsFrame};

use super::held::HeldReplication;
use crate::channels::{self, Channel};
use crate::events::FrameRefusal;

/// A frame as received.
pub(crate) enum Frame {
    Replication(HeldReplication),
    Events(PhysicsEventsFrame),
}

impl Frame {
    /// Its sender.
    pub(crate) fn from(&self) -> ClusterId {
        match self {
            Frame::Replication(f) => f.from,
            Frame::Events(f) => f.from,
        }
    }

    /// Its sender's tick.
    pub(crate) fn tick(&self) -> u64 {
        match self {
            Frame::Replication(f) => f.tick,
            Frame::Events(f) => f.tick,
        }
    }

    /// Whether it is a replication frame.
    pub(crate) fn is_replication(&self) -> bool {
        matches!(self, Frame::Replication(_))
    }
}

fn refusal(error: wire::WireError) -> FrameRefusal {
    match error {
        wire::WireError::Version { .. } => FrameRefusal::WrongVersion,
        _ => FrameRefusal::Malformed,
    }
}

/// Decodes a message received on `channel`. A replication frame whose sender is not the
/// cluster its channel names, or a message on a channel that is not one of seam's, is from the
/// wrong sender.
pub(crate) fn decode_frame(channel: &str, payload: &[u8]) -> Result<Frame, FrameRefusal> {
    match channels::parse(channel).ok_or(FrameRefusal::WrongSender)? {
        Channel::Replication(from) => {
            // Checked in place; its states are read when the tick uses it.
            let frame = HeldReplication::new(payload).map_err(refusal)?;
            if frame.from != from {
                return Err(FrameRefusal::WrongSender);
            }
            Ok(Frame::Replication(frame))
        }
        Channel::PhysicsEvents(_) => wire::decode::<PhysicsEventsFrame>(payload)
            .map(Frame::Events)
            .map_err(refusal),
    }
}
