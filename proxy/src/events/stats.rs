//! What a cluster counts: [`ClusterStats`], a consumer of the event stream.

use super::event::{ClusterEvent, ContactGiveUp, FrameRefusal, OpDrop};

/// Declares the counters and their sum together, so a counter added to the struct is summed
/// too.
macro_rules! counters {
    ($(#[$meta:meta])* pub struct $name:ident { $($(#[$doc:meta])* pub $field:ident: u64,)* }) => {
        $(#[$meta])*
        pub struct $name {
            $($(#[$doc])* pub $field: u64,)*
        }

        impl std::ops::AddAssign<&$name> for $name {
            fn add_assign(&mut self, other: &$name) {
                $(self.$field += other.$field;)*
            }
        }

        /// The counters that are not zero, one `name value` a line, in the struct's order
        /// (`{:#}`: on one line, comma-separated); "nothing counted" when all are.
        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                let counted: Vec<(&str, u64)> = [$((stringify!($field), self.$field)),*]
                    .into_iter()
                    .filter(|&(_, n)| n > 0)
                    .collect();
                if counted.is_empty() {
                    return f.write_str("nothing counted");
                }
                let separator = if f.alternate() { ", " } else { "\n" };
                for (i, (name, n)) in counted.into_iter().enumerate() {
                    if i > 0 {
                        f.write_str(separator)?;
                    }
                    write!(f, "{name} {n}")?;
                }
                Ok(())
            }
        }
    };
}

counters! {
/// Counters of one cluster since it started. Counters of several clusters (or of one pod's
/// several lives) add up with `+=`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ClusterStats {
    /// Ticks run.
    pub ticks: u64,
    /// Proxies created for neighbour entities that became visible.
    pub proxies_spawned: u64,
    /// Proxies removed (entity left the region or its owner stopped listing it).
    pub proxies_despawned: u64,
    /// Writes on remote-owned entities made here and sent to their owners, each counted once
    /// however often it is sent.
    pub ops_routed: u64,
    /// Routed writes received and applied here.
    pub ops_applied: u64,
    /// Routed writes received for an entity this cluster does not own and could not forward:
    /// answered "not here", so the sender sends them where it now knows the entity to be.
    pub ops_not_here: u64,
    /// Routed writes received with invalid values (NaN, infinity): dropped.
    pub ops_dropped_invalid: u64,
    /// Routed writes with a value beyond `ClusterConfig::max_magnitude`: dropped.
    pub ops_dropped_absurd: u64,
    /// Contacts between a local body and a proxy, reported to the proxy's owner, each counted
    /// once however often it is sent.
    pub contacts_sent: u64,
    /// Contact reports sent again: unanswered after `ClusterConfig::op_retry_ticks`, or meant
    /// for a neighbour taken for dead (then sent to the other entity's owner after adoption).
    pub contacts_resent: u64,
    /// Contact reports answered by their receiver, and forgotten.
    pub contacts_acked: u64,
    /// Contact reports given up by their sender: unanswered past `max_op_age_ticks` and the
    /// time an owner may stay silent, out of this world's view with the last receiver gone,
    /// or the queue for the owner full.
    pub contacts_given_up: u64,
    /// Contact reports forgotten unanswered because both bodies became this cluster's own
    /// (adopted from a dead neighbour, or handed here): this cluster's game code saw the
    /// contact itself, and no other owner is left to tell.
    pub contacts_own_now: u64,
    /// Contact reports received from neighbours, repeats included.
    pub contacts_received: u64,
    /// Of those, reports surfaced (or merged) here before: answered, not surfaced again.
    pub contacts_repeated: u64,
    /// Of those, reports older than `ClusterConfig::max_op_age_ticks` (or than the window of
    /// numbers kept): dropped, answered.
    pub contacts_dropped_stale: u64,
    /// Contacts seen twice — in this world and in a neighbour's report — and surfaced once
    /// (see `crate::contacts`): the second copies, dropped.
    pub contacts_merged: u64,
    /// Contacts across the seam whose impulse on a body of this cluster was sent to the other
    /// body's owner, to settle (see `crate::contacts`).
    pub seam_impulses_sent: u64,
    /// Such reports received from neighbours.
    pub seam_impulses_received: u64,
    /// Of those, reports naming a body this cluster does not simulate (handed on since) or
    /// carrying a value that is not finite or beyond `ClusterConfig::max_magnitude`: ignored.
    pub seam_impulses_dropped: u64,
    /// Settling impulses given to this cluster's bodies (one per body and tick).
    pub seam_impulses_settled: u64,
    /// Pairs whose two worlds' impulses disagreed too much to be one contact: left unsettled.
    pub seam_impulses_disagreed: u64,
    /// Impulses (this world's or a report) whose other half did not come in time.
    pub seam_impulses_unmatched: u64,
    /// Of those, this world's: contacts the other world did not see, whose push went to the
    /// other body's owner as a routed impulse (counted in `ops_routed` too).
    pub seam_impulses_routed: u64,
    /// Of those, this world's whose other world had not published its reports of that step
    /// (stalled, dead, or lagging past the wait): nothing to judge by, so nothing routed.
    pub seam_impulses_unjudged: u64,
    /// Times a proxy was made a dynamic body of its entity's mass because a body simulated
    /// here could touch it (see `seam_sim::coupling`).
    pub proxies_coupled: u64,
    /// Times an impulse game code routed to an entity's owner was added to this world's coupled
    /// proxy of it, until the owner's frames carry it (see `crate::contacts`).
    pub impulses_predicted: u64,
    /// Free-running, exchange frames of a live neighbour that did not come in time for this
    /// cluster's step (their ops applied a tick late; see `ClusterConfig::exchange`).
    pub exchanges_missed: u64,
    /// Entities handed to this cluster while it held no proxy of them (taken from the
    /// hand-off's state, with nothing around them modelled before).
    pub handoffs_in_without_proxy: u64,
    /// Free-running, ticks that started without a live neighbour's frames of the step before
    /// (it was later than `ClusterConfig::neighbour_wait_ticks`).
    pub steps_missed: u64,
    /// Impulses neighbours said they gave their own bodies, not shown here: not finite or
    /// beyond `ClusterConfig::max_magnitude`.
    pub own_writes_rejected: u64,
    /// Entities handed to another cluster.
    pub handoffs_out: u64,
    /// Entities taken over from another cluster.
    pub handoffs_in: u64,
    /// Frames taken in (from a neighbour, decoded, first of their sender and tick).
    pub frames_accepted: u64,
    /// Received frames that did not decode.
    pub frames_malformed: u64,
    /// Received frames of another wire format version.
    pub frames_wrong_version: u64,
    /// Frames whose sender is not a neighbour, or not the cluster their channel names.
    pub frames_wrong_sender: u64,
    /// A frame of a live sender tagged no later than one of its frames already taken (a second
    /// frame of a tick, or an old one: a replay or a forgery): the first is kept.
    pub frames_replayed: u64,
    /// States ignored: sent by a cluster that is not the entity's owner, invalid, or beyond
    /// `ClusterConfig::max_magnitude`.
    pub states_rejected: u64,
    /// Events not kept because the caller did not take them (see `Cluster::take_events`).
    pub events_dropped: u64,
    /// Bytes of replication frames published (encoded frames, without transport framing).
    pub replication_bytes: u64,
    /// States the replication frames published stand for: this cluster's own and repeated
    /// hand-offs, listed or (in a delta frame) marked unchanged.
    pub states_replicated: u64,
    /// Of those, states a delta frame marked unchanged rather than listed (see
    /// `ClusterConfig::keyframe_ticks`).
    pub states_unchanged: u64,
    /// Replication frames published whole (keyframes).
    pub keyframes_sent: u64,
    /// Delta frames received whose keyframe this cluster did not hold (lost or not yet
    /// received): used for what they list, with nothing despawned, until the next keyframe.
    pub keyframes_missed: u64,
    /// Bytes of physics-events frames published.
    pub events_bytes: u64,
    /// Neighbours taken for dead after `neighbour_timeout_ticks` of silence (their proxies
    /// despawned).
    pub neighbours_lost: u64,
    /// Neighbours that said they were stopping on purpose (see `Cluster::leave`).
    pub neighbours_left: u64,
    /// Hand-offs to a neighbour that left before taking them, taken back (apart from
    /// `handoffs_reclaimed`, which counts those taken back from a neighbour taken for dead and
    /// returned to it when it is back).
    pub handoffs_taken_back: u64,
    /// Neighbours heard from again after being taken for dead.
    pub neighbours_rejoined: u64,
    /// Entities of a neighbour taken for dead that this cluster adopted (see
    /// `ClusterConfig::world`).
    pub entities_adopted: u64,
    /// Entities handed to a neighbour that was taken for dead before it took them: taken back.
    pub handoffs_reclaimed: u64,
    /// Hand-offs a live neighbour did not answer within `neighbour_timeout_ticks`: taken
    /// back (each logged by name).
    pub handoffs_returned: u64,
    /// Entities taken over here and claimed back by their giver, which had given up waiting
    /// for the answer (see `handoffs_returned`): this copy became a proxy.
    pub handoffs_yielded: u64,
    /// Adopted entities handed back to their owner when it was heard from again.
    pub entities_returned: u64,
    /// Adopted entities (or hand-offs taken back) claimed at a later epoch by another cluster
    /// and yielded to it: not returned, nothing to return.
    pub adoptions_yielded: u64,
    /// Frames tagged further ahead than a live sender could be (see the crate docs on
    /// liveness): dropped as forged.
    pub frames_implausible: u64,
    /// Frames from a pod older than one of the same cluster heard since (its incarnation):
    /// a pod taken over that still publishes, or its frames still on their way.
    pub frames_stale: u64,
    /// Of `handoffs_out`, those the authority policy asked for (the rest game code asked for,
    /// or returned adopted entities).
    pub handoffs_by_policy: u64,
    /// Routed writes received for an entity this cluster no longer owned and sent on, once,
    /// to the owner it knew (this cluster then sees them answered; a forwarded op that misses
    /// again is answered "not here" to it).
    pub ops_forwarded: u64,
    /// Routed writes sent again: unanswered after `op_retry_ticks`, or answered "not here".
    pub ops_resent: u64,
    /// Routed writes this cluster sent that were answered done.
    pub ops_acked: u64,
    /// Routed writes received again after being closed here: answered, not applied again.
    pub ops_repeated: u64,
    /// Routed writes received older than `max_op_age_ticks`: dropped as stale.
    pub ops_dropped_stale: u64,
    /// Routed writes this cluster gave up, unanswered `max_op_age_ticks` and twice
    /// `neighbour_timeout_ticks` after they were made: no owner could be reached (or one
    /// applied them and died before its answer went out).
    pub ops_expired: u64,
    /// Routed writes dropped because their entity exists nowhere this cluster or the one it
    /// was sent to knows of.
    pub ops_dropped_gone: u64,
    /// Routed writes received with a number older than the window of closed numbers of their issuer
    /// (see `WINDOW` in `crate::delivery`, 16 384): they cannot be told from repeats, so dropped.
    pub ops_dropped_window: u64,
    /// Routed writes not sent: already `MAX_UNANSWERED` (4 096, `crate::delivery`) unanswered for their
    /// owner.
    pub ops_dropped_queue_full: u64,
    /// Issuers whose closed numbers were forgotten to make room (see
    /// `MAX_ISSUERS`, 256, in `crate::delivery`).
    pub op_windows_forgotten: u64,
}
}

impl ClusterStats {
    /// The frames refused for `reason` so far.
    pub fn frames_refused_for(&self, reason: FrameRefusal) -> u64 {
        let mut copy = *self;
        *copy.refused_mut(reason)
    }

    fn refused_mut(&mut self, reason: FrameRefusal) -> &mut u64 {
        match reason {
            FrameRefusal::Malformed => &mut self.frames_malformed,
            FrameRefusal::WrongVersion => &mut self.frames_wrong_version,
            FrameRefusal::WrongSender => &mut self.frames_wrong_sender,
            FrameRefusal::Replayed => &mut self.frames_replayed,
            FrameRefusal::Implausible => &mut self.frames_implausible,
            FrameRefusal::StaleIncarnation => &mut self.frames_stale,
        }
    }

    /// Counts one event.
    pub(crate) fn count(&mut self, event: &ClusterEvent) {
        use ClusterEvent as E;
        match *event {
            E::Ticked => self.ticks += 1,
            E::FrameAccepted { .. } => self.frames_accepted += 1,
            E::FrameRefused { reason, .. } => *self.refused_mut(reason) += 1,
            E::StateRejected { .. } => self.states_rejected += 1,
            E::KeyframeMissed { .. } => self.keyframes_missed += 1,
            E::ReplicationPublished {
                bytes,
                states,
                unchanged,
                keyframe,
            } => {
                self.replication_bytes += bytes;
                self.states_replicated += states;
                self.states_unchanged += unchanged;
                self.keyframes_sent += u64::from(keyframe);
            }
            E::EventsPublished { bytes, .. } => self.events_bytes += bytes,
            E::ProxySpawned { .. } => self.proxies_spawned += 1,
            E::ProxyDespawned { .. } => self.proxies_despawned += 1,
            E::ProxiesCoupled { count } => self.proxies_coupled += count,
            E::ImpulsesPredicted { count } => self.impulses_predicted += count,
            E::ExchangeMissed { .. } => self.exchanges_missed += 1,
            E::HandoffWithoutProxy { .. } => self.handoffs_in_without_proxy += 1,
            E::StepMissed { .. } => self.steps_missed += 1,
            E::OwnWriteRejected { .. } => self.own_writes_rejected += 1,
            E::OpSent { .. }
            | E::OpResent { .. }
            | E::OpAnswered { .. }
            | E::OpForwarded { .. }
            | E::OpNotHere { .. }
            | E::OpRepeated { .. }
            | E::OpApplied { .. }
            | E::OpDropped { .. }
            | E::OpWindowsForgotten { .. }
            | E::ContactReported { .. }
            | E::ContactResent { .. }
            | E::ContactAnswered { .. }
            | E::ContactGivenUp { .. }
            | E::ContactReceived { .. }
            | E::ContactRepeated { .. }
            | E::ContactStale { .. }
            | E::ContactDelivered { .. }
            | E::ContactsMerged { .. } => self.count_delivered(event),
            E::SeamImpulseSent { .. } => self.seam_impulses_sent += 1,
            E::SeamImpulseReceived => self.seam_impulses_received += 1,
            E::SeamImpulseDropped => self.seam_impulses_dropped += 1,
            E::SeamImpulseSettled { .. } => self.seam_impulses_settled += 1,
            E::SeamImpulsesDisagreed { count } => self.seam_impulses_disagreed += count,
            E::SeamImpulsesUnmatched { count } => self.seam_impulses_unmatched += count,
            E::SeamImpulseRouted { .. } => self.seam_impulses_routed += 1,
            E::SeamImpulseUnjudged => self.seam_impulses_unjudged += 1,
            E::HandoffAsked { .. } => self.handoffs_by_policy += 1,
            E::HandoffGiven { .. } => self.handoffs_out += 1,
            E::HandoffTaken { .. } => self.handoffs_in += 1,
            E::HandoffTakenBack { .. } => self.handoffs_taken_back += 1,
            E::HandoffReclaimed { .. } => self.handoffs_reclaimed += 1,
            E::HandoffReturned { .. } => self.handoffs_returned += 1,
            E::HandoffYielded { .. } => self.handoffs_yielded += 1,
            E::AdoptionYielded { .. } => self.adoptions_yielded += 1,
            E::NeighbourLost { .. } => self.neighbours_lost += 1,
            E::NeighbourLeft { .. } => self.neighbours_left += 1,
            E::NeighbourRejoined { .. } => self.neighbours_rejoined += 1,
            E::EntityAdopted { .. } => self.entities_adopted += 1,
            E::EntityReturned { .. } => self.entities_returned += 1,
        }
    }

    /// Counts an event of a routed op or a contact report.
    fn count_delivered(&mut self, event: &ClusterEvent) {
        use ClusterEvent as E;
        match *event {
            E::OpSent { issued_here, .. } => self.ops_routed += u64::from(issued_here),
            E::OpResent { .. } => self.ops_resent += 1,
            E::OpAnswered { .. } => self.ops_acked += 1,
            E::OpForwarded { .. } => self.ops_forwarded += 1,
            E::OpNotHere { .. } => self.ops_not_here += 1,
            E::OpRepeated { .. } => self.ops_repeated += 1,
            E::OpApplied { .. } => self.ops_applied += 1,
            E::OpDropped { reason, .. } => {
                *match reason {
                    OpDrop::Invalid => &mut self.ops_dropped_invalid,
                    OpDrop::Absurd => &mut self.ops_dropped_absurd,
                    OpDrop::Stale => &mut self.ops_dropped_stale,
                    OpDrop::Expired => &mut self.ops_expired,
                    OpDrop::Gone => &mut self.ops_dropped_gone,
                    OpDrop::Window => &mut self.ops_dropped_window,
                    OpDrop::QueueFull => &mut self.ops_dropped_queue_full,
                } += 1
            }
            E::OpWindowsForgotten { count } => self.op_windows_forgotten += count,
            E::ContactReported { .. } => self.contacts_sent += 1,
            E::ContactResent { .. } => self.contacts_resent += 1,
            E::ContactAnswered { .. } => self.contacts_acked += 1,
            E::ContactGivenUp { reason, .. } => match reason {
                ContactGiveUp::OwnNow => self.contacts_own_now += 1,
                _ => self.contacts_given_up += 1,
            },
            E::ContactReceived { .. } => self.contacts_received += 1,
            E::ContactRepeated { .. } => self.contacts_repeated += 1,
            E::ContactStale { .. } => self.contacts_dropped_stale += 1,
            E::ContactDelivered { .. } => {}
            E::ContactsMerged { count } => self.contacts_merged += count,
            _ => {}
        }
    }

    /// Routed writes this cluster dropped for good, every reason: invalid, absurd, stale,
    /// expired unanswered, their entity gone, out of the window, or the queue full. With
    /// `ops_applied`, what became of every op (summed over clusters, each op ends in exactly
    /// one of these unless an answer was lost and the sender let it expire).
    pub fn ops_dropped(&self) -> u64 {
        self.ops_dropped_invalid
            + self.ops_dropped_absurd
            + self.ops_dropped_stale
            + self.ops_expired
            + self.ops_dropped_gone
            + self.ops_dropped_window
            + self.ops_dropped_queue_full
    }

    /// Frames this cluster refused, every reason (the transport's own drops aside).
    pub fn frames_refused(&self) -> u64 {
        self.frames_malformed
            + self.frames_wrong_version
            + self.frames_wrong_sender
            + self.frames_replayed
            + self.frames_implausible
            + self.frames_stale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_count_every_reason() {
        let one = ClusterStats {
            ops_dropped_invalid: 1,
            ops_dropped_absurd: 1,
            ops_dropped_stale: 1,
            ops_expired: 1,
            ops_dropped_gone: 1,
            ops_dropped_window: 1,
            ops_dropped_queue_full: 1,
            frames_malformed: 1,
            frames_wrong_version: 1,
            frames_wrong_sender: 1,
            frames_replayed: 1,
            frames_implausible: 1,
            ticks: 7,
            ..ClusterStats::default()
        };
        let mut two = one;
        two += &one;
        assert_eq!(
            (two.ops_dropped(), two.frames_refused(), two.ticks),
            (14, 10, 14)
        );
    }

    #[test]
    fn display_lists_what_was_counted() {
        let mut stats = ClusterStats::default();
        assert_eq!(stats.to_string(), "nothing counted");
        stats.ticks = 3;
        stats.handoffs_returned = 1;
        assert_eq!(stats.to_string(), "ticks 3\nhandoffs_returned 1");
        assert_eq!(format!("{stats:#}"), "ticks 3, handoffs_returned 1");
    }
}
