//! [`Publisher`]: this cluster's replication frame — its own states, the hand-offs it makes
//! and repeats, as a keyframe or a delta frame, encoded straight into the transport's buffer.

use seam_sim::wire::{
    self, ClusterId, DeltaBase, EntityState, ReplicationEncoder, ReplicationFrame,
};
use seam_sim::{BodyRole, ClusterSim};
use seam_transport::Transport;

use super::interest::Interest;
use super::keyframes::{Keyframes, Plan};
use crate::channels;
use crate::config::ClusterConfig;
use crate::error::ClusterError;
use crate::events::{ClusterEvent, Events};
use crate::handoff::Handoffs;

/// The sender's side of replication, with buffers kept from frame to frame.
#[derive(Debug)]
pub(crate) struct Publisher {
    channel: String,
    /// The pod's incarnation, stamped on every frame.
    incarnation: u64,
    /// Tables reused by every frame.
    encoder: ReplicationEncoder,
    /// The last keyframe sent, for the delta frames after it.
    keyframes: Keyframes,
    /// The owned states and roles gathered for the last frame, and its states: buffers kept
    /// for the next, so a steady-state publish allocates nothing here.
    owned: Vec<(EntityState, BodyRole)>,
    states: Vec<EntityState>,
}

/// The hand-offs a frame carries: those in transit always, the queued ones unless `held`
/// (while the transport is down; see `Cluster::publish_replication`).
pub(crate) struct FrameHandoffs<'a> {
    pub(crate) handoffs: &'a Handoffs,
    pub(crate) held: bool,
}

impl Publisher {
    /// The publisher of `config`'s cluster.
    pub(crate) fn new(config: &ClusterConfig, incarnation: u64) -> Self {
        Self {
            channel: channels::replication(config.cluster_id),
            incarnation,
            encoder: ReplicationEncoder::default(),
            keyframes: Keyframes::new(config.keyframe_ticks, config.replication_interval),
            owned: Vec::new(),
            states: Vec::new(),
        }
    }

    /// This cluster's replication channel.
    pub(crate) fn channel(&self) -> &str {
        &self.channel
    }

    /// Gathers the entities `me` owns in `sim`, with their states and roles, for this frame.
    pub(crate) fn gather(&mut self, sim: &ClusterSim, me: ClusterId) -> &[(EntityState, BodyRole)] {
        self.owned.clear();
        debug_assert_eq!(me, sim.config().cluster_id);
        self.owned.extend(sim.owned_states());
        &self.owned
    }

    /// Publishes the frame of `tick` from the states gathered: the queued hand-offs carry
    /// their new owner (unless they are held: they stay queued), the room around this
    /// cluster's own bodies is followed, and the hand-offs in transit ride along again.
    /// Returns the hand-offs made.
    pub(crate) fn publish(
        &mut self,
        transport: &mut dyn Transport,
        config: &ClusterConfig,
        tick: u64,
        handoffs: FrameHandoffs<'_>,
        interest: &mut Interest,
        events: &mut Events,
    ) -> Result<Vec<EntityState>, ClusterError> {
        let me = config.cluster_id;
        let mut states = std::mem::take(&mut self.states);
        states.clear();
        states.extend(self.owned.iter().map(|(s, _)| *s));
        let FrameHandoffs { handoffs, held } = handoffs;
        let handing = if held {
            Vec::new()
        } else {
            handoffs.mark(&mut states)
        };
        interest.follow(
            states.iter().filter(|s| s.cluster_id == me),
            config.sweep_s(),
            config.spread,
        );
        states.extend(handoffs.in_transit());
        let whole = states.len();
        let plan = self.keyframes.plan(me, tick, &mut states);
        let unchanged = (whole - states.len()) as u64;
        let base = match plan {
            Plan::Key => None,
            Plan::Delta {
                key_tick,
                key_states,
            } => Some(self.keyframes.base(key_tick, key_states)),
        };
        let frame = ReplicationFrame {
            from: me,
            tick,
            incarnation: self.incarnation,
            states,
        };
        let len = encode_into(
            transport,
            &self.channel,
            &mut self.encoder,
            &frame,
            config.state_encoding,
            base,
        );
        self.states = frame.states;
        events.emit(ClusterEvent::ReplicationPublished {
            bytes: len? as u64,
            states: whole as u64,
            unchanged,
            keyframe: plan == Plan::Key,
        });
        Ok(handing)
    }
}

/// Encodes a replication frame straight into the transport's buffer, its records written in
/// place (a delta frame when `base` is given); returns the encoded length.
fn encode_into(
    transport: &mut dyn Transport,
    channel: &str,
    encoder: &mut ReplicationEncoder,
    frame: &ReplicationFrame,
    encoding: wire::StateEncoding,
    base: Option<DeltaBase<'_>>,
) -> Result<usize, ClusterError> {
    let len = match base {
        Some(base) => encoder.prepare_delta(frame, encoding, base)?,
        None => encoder.prepare(frame, encoding)?,
    };
    transport.publish_with(channel, len, &mut |buffer| {
        encoder.write(frame, buffer).ok()
    })?;
    Ok(len)
}
