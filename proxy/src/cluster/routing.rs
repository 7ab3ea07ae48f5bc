//! Routed writes: game code's writes on remote-owned entities queued by owner, the ops received
//! for this cluster's entities applied once (or forwarded once after a hand-off) and answered,
//! and this cluster's unanswered ops sent again to whoever owns their target now (see
//! `crate::delivery`).

use seam_sim::wire::{ClusterId, IdMap, OpAck, PhysicsEventsFrame, PhysicsOp, RoutedOp};
use seam_sim::{SimError, WriteRouter};

use crate::clock::{OpTiming, monotonic_ns};
use crate::delivery::{OpKey, Verdict};
use crate::ledger::LedgerEvent;

use super::{Cluster, MAX_OP_TIMINGS, NeighbourStatus, within};

/// Writes on remote-owned entities, queued by owner until the tick publishes.
pub(super) struct Outbox<'a> {
    pub(super) neighbours: &'a [ClusterId],
    pub(super) ops: &'a mut IdMap<ClusterId, Vec<RoutedOp>>,
    pub(super) next_seq: &'a mut u64,
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
        let seq = *self.next_seq;
        *self.next_seq += 1;
        self.ops.entry(owner).or_default().push(RoutedOp {
            op,
            seq,
            issuer: None,
            issued_ns: monotonic_ns(),
            issued_tick: self.tick,
            age_ticks: 0,
        });
        Ok(())
    }
}

/// Where a received op came from, for its stage times.
struct Arrival {
    published_ns: u64,
    received_ns: u64,
}

impl Cluster {
    /// Whether `cluster` is a neighbour not taken for dead and not gone.
    fn reachable(&self, cluster: ClusterId) -> bool {
        self.config.neighbours.contains(&cluster)
            && !self
                .neighbour_status(cluster)
                .is_some_and(NeighbourStatus::is_gone)
    }

    /// Takes in the answers to the ops this cluster sent: settled ones are forgotten, those
    /// "not here" are sent again this tick to where the target is now.
    pub(super) fn take_acks(&mut self, events: &[(PhysicsEventsFrame, u64)], tick: u64) {
        let me = self.config.cluster_id;
        for (frame, _) in events {
            for ack in &frame.acks {
                let issuer = ack.issuer.unwrap_or(me);
                for seq in ack.seqs() {
                    let key = (issuer, seq);
                    if ack.done {
                        if self.outstanding.take(key).is_some() {
                            self.stats.ops_acked += 1;
                            self.note_op(key, LedgerEvent::Answered);
                        } else if self.outstanding_contacts.take(key).is_some() {
                            self.stats.contacts_acked += 1;
                            self.note_contact(key, LedgerEvent::Answered);
                        }
                    } else {
                        self.outstanding.returned(key, tick);
                        self.outstanding_contacts.returned(key, tick);
                    }
                }
            }
        }
    }

    /// Answers an op received from `to` in its next events frame.
    fn answer(&mut self, to: ClusterId, routed: &RoutedOp, done: bool) {
        self.answer_number(to, routed.seq, routed.issuer, done);
    }

    /// Answers number `seq` of `issuer` (`None`: `to` itself) received from `to`, an op or a
    /// contact report, in its next events frame: the answer to the number before it grows
    /// when the two are consecutive numbers of one issuer, answered alike.
    pub(super) fn answer_number(
        &mut self,
        to: ClusterId,
        seq: u64,
        issuer: Option<ClusterId>,
        done: bool,
    ) {
        let acks = self.outgoing_acks.entry(to).or_default();
        if let Some(last) = acks.last_mut()
            && last.issuer == issuer
            && last.done == done
            && last.more < u16::MAX
            && last.seq.checked_add(u64::from(last.more) + 1) == Some(seq)
        {
            last.more += 1;
            return;
        }
        acks.push(OpAck {
            seq,
            more: 0,
            issuer,
            done,
        });
    }

    /// Applies the ops received for this cluster's entities, just before the step, each name
    /// once; an op whose target was handed over since the issuer routed it is taken on and
    /// sent, once, to the owner this cluster knows; one it cannot place is answered "not
    /// here"; absurd, stale, invalid and repeated ops are counted and dropped. Every op is
    /// answered.
    pub(super) fn apply_routed_ops(&mut self, events: &[(PhysicsEventsFrame, u64)], tick: u64) {
        for (frame, received_ns) in events {
            let arrival = Arrival {
                published_ns: frame.published_ns,
                received_ns: *received_ns,
            };
            for routed in &frame.ops {
                let key = (routed.issuer.unwrap_or(frame.from), routed.seq);
                match self.settled.verdict(key) {
                    Verdict::Repeat => {
                        self.stats.ops_repeated += 1;
                        self.answer(frame.from, routed, true);
                        continue;
                    }
                    Verdict::TooOld => {
                        self.stats.ops_dropped_window += 1;
                        self.note_op(key, LedgerEvent::Dropped);
                        self.answer(frame.from, routed, true);
                        continue;
                    }
                    Verdict::New => {}
                }
                if let Some(v) = routed.op.vector()
                    && v.iter().all(|c| c.is_finite())
                    && !within(v, self.config.max_magnitude)
                {
                    self.settle(key);
                    self.stats.ops_dropped_absurd += 1;
                    self.note_op(key, LedgerEvent::Dropped);
                    self.answer(frame.from, routed, true);
                    continue;
                }
                // Its age when applied: the ticks it spent in its senders' hands and the one it
                // waits here.
                if u64::from(routed.age_ticks) + 1 > self.config.max_op_age_ticks {
                    self.settle(key);
                    self.stats.ops_dropped_stale += 1;
                    self.note_op(key, LedgerEvent::Stale);
                    self.answer(frame.from, routed, true);
                    continue;
                }
                let owner = self.sim.info(routed.op.target()).map(|info| info.owner);
                match owner {
                    Some(owner) if owner == self.config.cluster_id => {
                        self.apply_here(key, routed, &arrival, tick);
                        self.answer(frame.from, routed, true);
                    }
                    // Handed over since the issuer routed it: taken on and sent, once, to the
                    // owner this cluster knows, which answers this cluster.
                    Some(owner) if !routed.forwarded() && self.reachable(owner) => {
                        self.settle(key);
                        self.outgoing_ops.entry(owner).or_default().push(RoutedOp {
                            issuer: Some(frame.from),
                            age_ticks: routed.age_ticks.saturating_add(1),
                            ..*routed
                        });
                        self.stats.ops_forwarded += 1;
                        self.answer(frame.from, routed, true);
                    }
                    _ => {
                        self.stats.ops_not_here += 1;
                        self.answer(frame.from, routed, false);
                    }
                }
            }
        }
    }

    /// Marks an op (or contact report) settled here.
    pub(super) fn settle(&mut self, key: OpKey) {
        let forgotten = self.settled.forgotten;
        self.settled.settle(key);
        self.stats.op_windows_forgotten += self.settled.forgotten - forgotten;
    }

    /// Applies an op on an entity this cluster owns, and keeps its stage times.
    fn apply_here(&mut self, key: OpKey, routed: &RoutedOp, arrival: &Arrival, tick: u64) {
        self.settle(key);
        match self.sim.apply_op(&routed.op) {
            Ok(()) => {
                self.stats.ops_applied += 1;
                self.note_on_body(key, LedgerEvent::Applied, routed.op.target());
                let timing = OpTiming {
                    from: key.0,
                    target: routed.op.target(),
                    issued_ns: routed.issued_ns,
                    published_ns: arrival.published_ns,
                    received_ns: arrival.received_ns,
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
            Err(_) => {
                self.stats.ops_dropped_invalid += 1;
                self.note_op(key, LedgerEvent::Dropped);
            }
        }
    }

    /// Sends again the unanswered ops that are due, each to the cluster this one now knows to
    /// own its target (or applies it, if that is this cluster); gives up on those too old to
    /// be applied anywhere, and on those whose entity neither this cluster nor the last
    /// receiver knows.
    pub(super) fn resend_due(&mut self, tick: u64) {
        let me = self.config.cluster_id;
        for (key, mut pending) in self.outstanding.take_due(tick) {
            let age = pending.age(tick);
            if self.past_answering(age) {
                self.stats.ops_expired += 1;
                self.note_op(key, LedgerEvent::GivenUp);
                continue;
            }
            let target = pending.sent.op.target();
            let owner = self.sim.info(target).map(|info| info.owner);
            let to = match owner {
                Some(owner) if owner == me => {
                    // Adopted or handed here since: applied here, once, if young enough.
                    if self.settled.verdict(key) == Verdict::New
                        && age + 1 > self.config.max_op_age_ticks
                    {
                        self.settle(key);
                        self.stats.ops_dropped_stale += 1;
                        self.note_on_body(key, LedgerEvent::Stale, target);
                    } else if self.settled.verdict(key) == Verdict::New {
                        let arrival = Arrival {
                            published_ns: monotonic_ns(),
                            received_ns: monotonic_ns(),
                        };
                        let routed = pending.sent;
                        self.apply_here(key, &routed, &arrival, tick);
                    } else {
                        self.stats.ops_repeated += 1;
                    }
                    continue;
                }
                Some(owner) if self.reachable(owner) => Some(owner),
                // Its owner is taken for dead: its entities are being adopted; wait for the
                // adopter's frames to name it.
                Some(owner) if self.config.neighbours.contains(&owner) => None,
                // Scenery, or an owner this cluster cannot send to.
                Some(_) => {
                    self.stats.ops_dropped_gone += 1;
                    self.note_op(key, LedgerEvent::Dropped);
                    continue;
                }
                // Not in this world: the last receiver may still place it, unless it said it
                // could not.
                None if pending.returned || !self.reachable(pending.to) => {
                    if pending.returned {
                        self.stats.ops_dropped_gone += 1;
                        self.note_op(key, LedgerEvent::Dropped);
                        continue;
                    }
                    None
                }
                None => Some(pending.to),
            };
            pending.returned = false;
            pending.due_tick = tick + self.config.op_retry_ticks.max(1);
            if let Some(to) = to {
                pending.to = to;
                self.outgoing_ops.entry(to).or_default().push(RoutedOp {
                    issuer: (key.0 != me).then_some(key.0),
                    age_ticks: u32::try_from(age).unwrap_or(u32::MAX),
                    ..pending.sent
                });
                self.stats.ops_resent += 1;
            }
            if !self.outstanding.keep(key, pending) {
                self.stats.ops_dropped_queue_full += 1;
                self.note_op(key, LedgerEvent::Dropped);
            }
        }
    }

    /// Whether an op (or contact report) unanswered at `age` is given up. Past its age limit
    /// any owner drops it as stale — unless it settled it already (its answer lost, say to an
    /// outage): so it is still sent, to be answered either way, for as long as an owner may
    /// stay silent and still be alive. Only then, with no answer, is it given up.
    pub(super) fn past_answering(&self, age: u64) -> bool {
        let answer_for = self.config.neighbour_timeout_ticks.max(1) * 2;
        age >= self.config.max_op_age_ticks + answer_for
    }

    /// Keeps the ops of this tick's frame to `to` until they are answered: those sent for the
    /// first time (issued here or taken on to forward) are added; resends are kept already.
    /// Returns the ops to send: those the queue for `to` had no room for are dropped.
    pub(super) fn keep_unanswered(
        &mut self,
        to: ClusterId,
        ops: Vec<RoutedOp>,
        tick: u64,
    ) -> Vec<RoutedOp> {
        let me = self.config.cluster_id;
        let retry = self.config.op_retry_ticks.max(1);
        let kept = self.outstanding.keep_sent(me, to, ops, tick, retry);
        for &key in kept.new.iter().chain(&kept.refused) {
            if key.0 == me {
                self.stats.ops_routed += 1;
            }
            self.note_op(key, LedgerEvent::Sent);
        }
        for &key in &kept.refused {
            self.stats.ops_dropped_queue_full += 1;
            self.note_op(key, LedgerEvent::Dropped);
        }
        kept.send
    }
}
