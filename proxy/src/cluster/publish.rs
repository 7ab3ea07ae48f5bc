//! Publishing a tick: the replication frame (after asking the authority policy), and one
//! physics-events frame per neighbour with its routed ops, contacts and impulses.

use seam_sim::BodyRole;
use seam_sim::wire::{
    self, DeltaBase, EntityState, PhysicsEventsFrame, ReplicationEncoder, ReplicationFrame,
};
use seam_transport::Transport;

use crate::authority::{AuthorityView, NeighbourView};
use crate::channels;
use crate::clock::monotonic_ns;
use crate::error::ClusterError;
use crate::keyframes::Plan;

use super::{Cluster, NeighbourStatus, RELEASED_FOR};

/// Encodes `frame` straight into the transport's buffer (on shm, the loaned sample); returns
/// the encoded length.
pub(super) fn publish_frame<T: serde::Serialize>(
    transport: &mut dyn Transport,
    channel: &str,
    frame: &T,
) -> Result<usize, ClusterError> {
    let len = wire::encoded_len(frame);
    transport.publish_with(channel, len, &mut |buffer| {
        wire::encode_into(frame, buffer).ok()
    })?;
    Ok(len)
}

/// Encodes a replication frame straight into the transport's buffer, its records written in
/// place (a delta frame when `base` is given); returns the encoded length.
pub(super) fn publish_replication(
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

impl Cluster {
    /// Asks the authority policy which of the `owned` entities to hand over in this frame, and
    /// queues those hand-offs that are valid and not already queued by game code.
    pub(super) fn ask_policy(&mut self, owned: &[(EntityState, BodyRole)]) {
        let Some(policy) = self.policy.as_mut() else {
            return;
        };
        let neighbours: Vec<NeighbourView> = self
            .config
            .neighbours
            .iter()
            .map(|&id| NeighbourView {
                id,
                region: self
                    .config
                    .world
                    .iter()
                    .find(|c| c.id == id)
                    .map(|c| c.region),
                alive: self
                    .liveness
                    .get(&id)
                    .is_none_or(|peer| !peer.status.is_gone()),
            })
            .collect();
        // Adopted entities stay in custody until their owner returns and gets them back.
        let custody: Vec<(EntityState, BodyRole)>;
        let owned = if self.adopted.is_empty() {
            owned
        } else {
            custody = owned
                .iter()
                .filter(|(state, _)| !self.adopted.contains_key(&state.id))
                .copied()
                .collect();
            &custody
        };
        let view = AuthorityView {
            cluster: self.config.cluster_id,
            tick: self.sim.tick(),
            region: self.config.region,
            lookahead_s: self.config.dt * self.config.replication_interval.max(1) as f32,
            neighbours: &neighbours,
            owned,
        };
        let mut handoffs = Vec::new();
        policy.decide(&view, &mut handoffs);
        for (entity, to) in handoffs {
            if self.transfers.contains_key(&entity) {
                continue;
            }
            if self.transfer_authority(entity, to).is_ok() {
                self.stats.handoffs_by_policy += 1;
            }
        }
    }

    /// Publishes this tick's replication frame (every `replication_interval` ticks, with any
    /// hand-offs) and one events frame per neighbour.
    pub(super) fn publish(&mut self) -> Result<(), ClusterError> {
        let me = self.config.cluster_id;
        let tick = self.sim.tick();
        if tick.is_multiple_of(self.config.replication_interval) {
            // Gathered into buffers kept from the last frame: a steady-state publish
            // allocates nothing here.
            let mut owned = std::mem::take(&mut self.scratch_owned);
            owned.clear();
            owned.extend(
                self.sim
                    .entities()
                    .filter(|(_, info)| info.owner == me)
                    .filter_map(|(id, info)| self.sim.state(id).map(|s| (s, info.role))),
            );
            self.ask_policy(&owned);
            let mut states = std::mem::take(&mut self.scratch_states);
            states.clear();
            states.extend(owned.iter().map(|(s, _)| *s));
            self.scratch_owned = owned;
            let mut handing = Vec::new();
            for state in &mut states {
                if let Some(&to) = self.transfers.get(&state.id) {
                    // The new owner rides with the final pose and velocity, read before the body
                    // becomes a proxy (a Fixed body loses its velocity), and the next epoch.
                    state.cluster_id = to;
                    state.epoch += 1;
                    handing.push(*state);
                }
            }
            let (sweep_s, spread) = (self.sweep_s(), self.config.spread);
            self.interest.follow(
                states.iter().filter(|s| s.cluster_id == me),
                sweep_s,
                spread,
            );
            // Earlier hand-offs not yet answered ride along again.
            states.extend(self.handed.values().copied());
            self.stats.states_replicated += states.len() as u64;
            let whole = states.len();
            let plan = self.keyframes.plan(me, tick, &mut states);
            self.stats.states_unchanged += (whole - states.len()) as u64;
            let base = match plan {
                Plan::Key => {
                    self.stats.keyframes_sent += 1;
                    None
                }
                Plan::Delta {
                    key_tick,
                    key_states,
                } => Some(self.keyframes.base(key_tick, key_states)),
            };
            let frame = ReplicationFrame {
                from: me,
                tick,
                states,
            };
            self.stats.replication_bytes += publish_replication(
                self.transport.as_mut(),
                &self.replication_channel,
                &mut self.encoder,
                &frame,
                self.config.state_encoding,
                base,
            )? as u64;
            self.scratch_states = frame.states;
            let role = self.proxy_role();
            self.transfers.clear();
            for handed in handing {
                let entity = handed.id;
                self.adopted.swap_remove(&entity);
                self.sim
                    .set_authority(entity, handed.cluster_id, handed.epoch)?;
                self.sim.set_role(entity, role)?;
                self.handed.insert(entity, handed);
                self.released.insert(entity, (handed.epoch, tick));
                self.stats.handoffs_out += 1;
                self.log_handoff(entity, false);
            }
            self.released
                .retain(|_, &mut (_, at)| tick.saturating_sub(at) <= RELEASED_FOR);
        }
        for i in 0..self.config.neighbours.len() {
            let neighbour = self.config.neighbours[i];
            let ops = self
                .outgoing_ops
                .get_mut(&neighbour)
                .map(std::mem::take)
                .unwrap_or_default();
            let mut ops = self.keep_unanswered(neighbour, ops, tick);
            let contacts = self
                .outgoing_contacts
                .get_mut(&neighbour)
                .map(std::mem::take)
                .unwrap_or_default();
            let mut contacts = self.keep_unanswered_contacts(neighbour, contacts, tick);
            if self
                .neighbour_status(neighbour)
                .is_some_and(NeighbourStatus::is_gone)
            {
                // Taken for dead: its entities are being adopted, so writes and contact reports
                // queued for it (before it was) are kept to go, next tick on, to whoever owns
                // their entities then. The empty frame still tells it, should it be alive
                // after all, that this cluster is.
                for op in ops.drain(..) {
                    self.outstanding
                        .due_at((op.issuer.unwrap_or(me), op.seq), tick + 1);
                }
                for report in contacts.drain(..) {
                    self.outstanding_contacts.due_at((me, report.seq), tick + 1);
                }
            }
            let frame = PhysicsEventsFrame {
                from: me,
                tick,
                published_ns: monotonic_ns(),
                ops,
                acks: self
                    .outgoing_acks
                    .get_mut(&neighbour)
                    .map(std::mem::take)
                    .unwrap_or_default(),
                contacts,
                impulses: self
                    .outgoing_impulses
                    .get_mut(&neighbour)
                    .map(std::mem::take)
                    .unwrap_or_default(),
                leaving: self.leaving,
            };
            self.stats.events_bytes += publish_frame(
                self.transport.as_mut(),
                &channels::physics_events(neighbour),
                &frame,
            )? as u64;
        }
        Ok(())
    }
}
