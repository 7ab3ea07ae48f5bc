//! Routed writes: game code's writes on remote-owned entities queued by owner, and the ops
//! received for this cluster's entities applied (or forwarded once after a hand-off).

use seam_sim::wire::{ClusterId, IdMap, PhysicsEventsFrame, PhysicsOp, RoutedOp};
use seam_sim::{SimError, WriteRouter};

use crate::clock::{OpTiming, monotonic_ns};

use super::{Cluster, MAX_OP_TIMINGS, NeighbourStatus, within};

/// Writes on remote-owned entities, queued by owner until the tick publishes.
pub(super) struct Outbox<'a> {
    pub(super) neighbours: &'a [ClusterId],
    pub(super) ops: &'a mut IdMap<ClusterId, Vec<RoutedOp>>,
    pub(super) tick: u64,
}

impl WriteRouter for Outbox<'_> {
    fn route(&mut self, owner: ClusterId, op: PhysicsOp) -> Result<(), SimError> {
        if !self.neighbours.contains(&owner) {
            return Err(SimError::NotOwned {
                entity: op.target(),
                owner,
            });
        }
        self.ops.entry(owner).or_default().push(RoutedOp {
            op,
            issued_ns: monotonic_ns(),
            issued_tick: self.tick,
            forwarded: false,
        });
        Ok(())
    }
}

impl Cluster {
    /// Applies the ops received for this cluster's entities, just before the step; an op whose
    /// target was handed over since the issuer routed it is sent on, once, to the owner this
    /// cluster knows; absurd, invalid and misdirected ops are counted and dropped.
    pub(super) fn apply_routed_ops(&mut self, events: &[(PhysicsEventsFrame, u64)], tick: u64) {
        for (frame, received_ns) in events {
            for routed in &frame.ops {
                if let Some(v) = routed.op.vector()
                    && v.iter().all(|c| c.is_finite())
                    && !within(v, self.config.max_magnitude)
                {
                    self.stats.ops_dropped_absurd += 1;
                    continue;
                }
                match self.sim.info(routed.op.target()) {
                    // Handed over since the issuer routed it: sent on, once, to the owner this
                    // cluster knows.
                    Some(info)
                        if info.owner != self.config.cluster_id
                            && !routed.forwarded
                            && self.config.neighbours.contains(&info.owner)
                            && !self
                                .neighbour_status(info.owner)
                                .is_some_and(NeighbourStatus::is_gone) =>
                    {
                        self.outgoing_ops
                            .entry(info.owner)
                            .or_default()
                            .push(RoutedOp {
                                forwarded: true,
                                ..*routed
                            });
                        self.stats.ops_forwarded += 1;
                    }
                    Some(info) if info.owner == self.config.cluster_id => {
                        match self.sim.apply_op(&routed.op) {
                            Ok(()) => {
                                self.stats.ops_applied += 1;
                                let timing = OpTiming {
                                    from: frame.from,
                                    target: routed.op.target(),
                                    issued_ns: routed.issued_ns,
                                    published_ns: frame.published_ns,
                                    received_ns: *received_ns,
                                    applied_ns: monotonic_ns(),
                                    issued_tick: routed.issued_tick,
                                    applied_tick: tick,
                                };
                                if self.op_timings.len() < MAX_OP_TIMINGS {
                                    self.op_timings.push(timing);
                                } else {
                                    self.stats.op_timings_dropped += 1;
                                }
                            }
                            Err(_) => self.stats.ops_dropped_invalid += 1,
                        }
                    }
                    _ => self.stats.ops_dropped_not_owner += 1,
                }
            }
        }
    }
}
