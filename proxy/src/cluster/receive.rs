//! Taking frames in: decoding them from the received bytes and filing them in the inbox, with
//! replays, implausible ticks and malformed bytes counted and dropped.

use std::sync::Arc;

use seam_sim::wire::{self, ClusterId, PhysicsEventsFrame};

use crate::channels::{self, Channel};
use crate::clock::monotonic_ns;
use crate::error::ClusterError;
use crate::inbox::HeldReplication;

use super::Cluster;

pub(super) enum Frame {
    Replication(HeldReplication),
    Events(PhysicsEventsFrame),
}

impl Frame {
    fn from(&self) -> ClusterId {
        match self {
            Frame::Replication(f) => f.from,
            Frame::Events(f) => f.from,
        }
    }

    fn tick(&self) -> u64 {
        match self {
            Frame::Replication(f) => f.tick,
            Frame::Events(f) => f.tick,
        }
    }

    fn is_replication(&self) -> bool {
        matches!(self, Frame::Replication(_))
    }
}

/// Why a received frame was not taken.
pub(super) enum Rejected {
    /// The bytes are not a frame of the channel's kind.
    Undecodable,
    /// A frame of another wire format version.
    WrongVersion,
    /// A replication frame whose sender is not the cluster its channel names, or a message on
    /// a channel that is not one of seam's.
    WrongSender,
}

pub(super) fn rejected(error: wire::WireError) -> Rejected {
    match error {
        wire::WireError::Version { .. } => Rejected::WrongVersion,
        _ => Rejected::Undecodable,
    }
}

/// Decodes a received frame straight from the received bytes.
pub(super) fn decode_frame(channel: &str, payload: &[u8]) -> Result<Frame, Rejected> {
    match channels::parse(channel).ok_or(Rejected::WrongSender)? {
        Channel::Replication(from) => {
            // Checked in place; its states are read when the tick uses it.
            let frame = HeldReplication::new(payload).map_err(rejected)?;
            if frame.from != from {
                return Err(Rejected::WrongSender);
            }
            Ok(Frame::Replication(frame))
        }
        Channel::PhysicsEvents(_) => wire::decode::<PhysicsEventsFrame>(payload)
            .map(Frame::Events)
            .map_err(rejected),
    }
}

impl Cluster {
    /// Keeps a keyframe, or gives a delta frame the keyframe it names (counted when this
    /// cluster does not hold it).
    fn read_against_key(&mut self, frame: &mut HeldReplication) {
        match frame.key_tick() {
            None => {
                let newer = self
                    .keys
                    .get(&frame.from)
                    .is_none_or(|&(tick, _)| tick <= frame.tick);
                if newer {
                    self.keys.insert(frame.from, (frame.tick, frame.bytes()));
                }
            }
            Some(key_tick) => match self.keys.get(&frame.from) {
                Some((tick, key)) if *tick == key_tick => frame.read_against(Arc::clone(key)),
                _ => self.stats.keyframes_missed += 1,
            },
        }
    }

    /// Moves everything the transport holds into the inbox.
    pub(super) fn drain(&mut self) -> Result<(), ClusterError> {
        while let Some(message) = self.transport.try_receive()? {
            let received_ns = monotonic_ns();
            // Decoded straight from the received bytes (on shm, the shared-memory sample).
            let frame = decode_frame(message.channel, message.payload);
            self.take_in(frame, received_ns);
        }
        Ok(())
    }

    /// Takes one received frame in: a malformed, implausible or replayed frame is counted and
    /// dropped; the others go to the inbox for the tick that uses them.
    pub(super) fn take_in(&mut self, frame: Result<Frame, Rejected>, received_ns: u64) {
        let kept = match frame {
            Ok(frame) if self.implausible(frame.from(), frame.tick()) => {
                self.stats.frames_implausible += 1;
                return;
            }
            Ok(frame) if self.replayed(frame.from(), frame.tick(), frame.is_replication()) => None,
            Ok(Frame::Replication(mut frame)) if self.config.neighbours.contains(&frame.from) => {
                self.read_against_key(&mut frame);
                let from = (frame.from, frame.tick, true);
                let kept = if self.free_running {
                    self.inbox.add_replication_newest(frame)
                } else {
                    self.inbox.add_replication(frame)
                };
                kept.then_some(from)
            }
            Ok(Frame::Events(frame)) if self.config.neighbours.contains(&frame.from) => {
                let from = (frame.from, frame.tick, false);
                self.inbox.add_events(frame, received_ns).then_some(from)
            }
            Ok(_) | Err(Rejected::WrongSender) => {
                self.stats.frames_wrong_sender += 1;
                return;
            }
            Err(Rejected::Undecodable) => {
                self.stats.frames_malformed += 1;
                return;
            }
            Err(Rejected::WrongVersion) => {
                self.stats.frames_wrong_version += 1;
                return;
            }
        };
        match kept {
            Some((from, tick, replication)) => {
                self.stats.frames_accepted += 1;
                self.heard(from, tick, replication);
            }
            None => self.stats.frames_replayed += 1,
        }
    }
}
