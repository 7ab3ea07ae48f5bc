//! A received message made a frame: decoded straight from the received bytes (on shm, the
//! shared-memory sample), or refused with the reason.

use seam_sim::wire::{self, ClusterId, PhysicsEventsFrame, Stage};
use seam_transport::Message;

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

    /// Its sender's incarnation.
    pub(crate) fn incarnation(&self) -> u64 {
        match self {
            Frame::Replication(f) => f.incarnation,
            Frame::Events(f) => f.incarnation,
        }
    }

    /// Its kind.
    pub(crate) fn kind(&self) -> FrameKind {
        match self {
            Frame::Replication(_) => FrameKind::Replication,
            Frame::Events(f) if f.stage == Stage::BeforeStep => FrameKind::Exchange,
            Frame::Events(_) => FrameKind::Events,
        }
    }
}

/// The kinds of frame a neighbour sends, one of each per tick, each numbered by tick on its
/// own (so a replay is told per kind).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FrameKind {
    /// Its replication frame.
    Replication = 0,
    /// Its physics-events frame after the step.
    Events = 1,
    /// Its physics-events frame before the step (the exchange).
    Exchange = 2,
}

impl FrameKind {
    /// How many kinds there are.
    pub(crate) const COUNT: usize = 3;
}

fn refusal(error: wire::WireError) -> FrameRefusal {
    match error {
        wire::WireError::Version { .. } => FrameRefusal::WrongVersion,
        _ => FrameRefusal::Malformed,
    }
}

/// Why a received message is no frame to take, and the sender it names, where it names one.
pub(crate) type Refused = (FrameRefusal, Option<ClusterId>);

/// Decodes a received message. A replication frame whose sender is not the cluster its
/// channel names, a frame whose sender is not the signer the transport checked (where it
/// checks signatures: a pod with west's key publishing as east), each refused naming the
/// sender it claims, or a message on a channel that is not one of seam's, is from the wrong
/// sender.
pub(crate) fn decode_frame(message: &Message<'_>) -> Result<Frame, Refused> {
    let frame = decode_payload(message.channel, message.payload)?;
    match message.signer {
        Some(signer) if signer != frame.from().as_u128() => {
            Err((FrameRefusal::WrongSender, Some(frame.from())))
        }
        _ => Ok(frame),
    }
}

fn decode_payload(channel: &str, payload: &[u8]) -> Result<Frame, Refused> {
    let unnamed = |reason| (reason, None);
    match channels::parse(channel).ok_or(unnamed(FrameRefusal::WrongSender))? {
        Channel::Replication(from) => {
            // Checked in place; its states are read when the tick uses it.
            let frame = HeldReplication::new(payload).map_err(|e| unnamed(refusal(e)))?;
            if frame.from != from {
                return Err((FrameRefusal::WrongSender, Some(frame.from)));
            }
            Ok(Frame::Replication(frame))
        }
        Channel::PhysicsEvents(_) => wire::decode::<PhysicsEventsFrame>(payload)
            .map(Frame::Events)
            .map_err(|e| unnamed(refusal(e))),
    }
}
