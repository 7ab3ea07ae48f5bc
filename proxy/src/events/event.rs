//! [`ClusterEvent`]: one thing that happened in a cluster.

use seam_sim::wire::{ClusterId, EntityId};

use super::timing::OpTiming;

/// What names a routed op or a contact report: its issuer and the issuer's number for it. Ops
/// and reports of one issuer are numbered from one counter, so a name is one or the other.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Name {
    /// The cluster that issued it.
    pub issuer: ClusterId,
    /// The issuer's number for it.
    pub seq: u64,
}

impl Name {
    /// Number `seq` of `issuer`.
    pub fn new(issuer: ClusterId, seq: u64) -> Self {
        Self { issuer, seq }
    }
}

/// Why a routed op was dropped for good.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum OpDrop {
    /// Invalid values (NaN, infinity) for the world it reached.
    Invalid,
    /// A value beyond `ClusterConfig::max_magnitude`.
    Absurd,
    /// Older than `ClusterConfig::max_op_age_ticks`.
    Stale,
    /// Given up by its sender: unanswered past its age limit and the time an owner may stay
    /// silent.
    Expired,
    /// Its entity exists nowhere this cluster or the one it was sent to knows of.
    Gone,
    /// Numbered older than the window of its issuer's numbers kept here: it cannot be told
    /// from a repeat.
    Window,
    /// Already `MAX_UNANSWERED` unanswered for its destination.
    QueueFull,
}

/// Why a sender gave up a contact report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ContactGiveUp {
    /// Unanswered past its age limit and the time an owner may stay silent.
    PastAnswering,
    /// Already `MAX_UNANSWERED` unanswered for its destination.
    QueueFull,
    /// Out of this world's view, with the last receiver gone: nobody left to tell.
    NobodyToTell,
    /// Both bodies are this cluster's own now (adopted, or handed here): its own game code saw
    /// the contact.
    OwnNow,
}

/// Why a received frame was not taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameRefusal {
    /// The bytes are not a frame of the channel's kind.
    Malformed,
    /// A frame of another wire format version.
    WrongVersion,
    /// From a cluster that is not a neighbour, or not the one its channel names.
    WrongSender,
    /// Tagged no later than a frame of the same kind its live sender sent before.
    Replayed,
    /// Tagged further ahead than a live sender could be.
    Implausible,
    /// From a pod of its cluster older than one heard since (taken over, still publishing).
    StaleIncarnation,
}

/// One thing that happened in a cluster (see the module docs). Each is emitted once, where
/// it happens; [`ClusterStats`](super::ClusterStats) documents what each counts towards.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum ClusterEvent {
    /// A tick ran to its end.
    Ticked,
    /// A frame was taken in from a neighbour.
    FrameAccepted {
        /// Its sender.
        from: ClusterId,
    },
    /// A received frame was refused.
    FrameRefused {
        /// Why.
        reason: FrameRefusal,
        /// The sender the frame names, where it could be read.
        from: Option<ClusterId>,
    },
    /// A replicated state was ignored: invalid, beyond the bound, or about an entity its
    /// sender does not own.
    StateRejected {
        /// The frame's sender.
        from: ClusterId,
    },
    /// A delta frame came without the keyframe it is read against.
    KeyframeMissed {
        /// Its sender.
        from: ClusterId,
    },
    /// This cluster's replication frame went out.
    ReplicationPublished {
        /// Encoded bytes.
        bytes: u64,
        /// States it stands for (own, and repeated hand-offs), listed or marked unchanged.
        states: u64,
        /// Of those, marked unchanged in a delta frame.
        unchanged: u64,
        /// Whether it was a keyframe.
        keyframe: bool,
    },
    /// A physics-events frame went out.
    EventsPublished {
        /// Its receiver.
        to: ClusterId,
        /// Encoded bytes.
        bytes: u64,
    },
    /// A proxy was made for a neighbour entity.
    ProxySpawned {
        /// The entity.
        entity: EntityId,
    },
    /// A proxy was removed.
    ProxyDespawned {
        /// The entity.
        entity: EntityId,
    },
    /// Proxies made dynamic bodies for the step (see `seam_sim::coupling`).
    ProxiesCoupled {
        /// How many.
        count: u64,
    },
    /// Routed impulses shown on this world's coupled proxies (see `crate::contacts`).
    ImpulsesPredicted {
        /// How many.
        count: u64,
    },
    /// An entity was handed to this cluster while it held no proxy of it (it is spawned from
    /// the hand-off's state; see `crate::authority`).
    HandoffWithoutProxy {
        /// The entity.
        entity: EntityId,
        /// Its old owner.
        from: ClusterId,
    },
    /// Free-running, a live neighbour's exchange frame of this tick did not come within
    /// `ClusterConfig::neighbour_wait_ticks`: its ops are applied a tick late.
    ExchangeMissed {
        /// The neighbour.
        neighbour: ClusterId,
    },
    /// Free-running, a live neighbour's frames of the step before did not come within
    /// `ClusterConfig::neighbour_wait_ticks` of this tick's start: this tick sees its last
    /// frames instead.
    StepMissed {
        /// The neighbour.
        neighbour: ClusterId,
    },
    /// An impulse a neighbour said it gave its own body was not shown here: not finite, or
    /// beyond `ClusterConfig::max_magnitude`.
    OwnWriteRejected {
        /// The neighbour.
        from: ClusterId,
    },
    /// A routed op went out for the first time from this cluster: issued here, or taken on to
    /// forward.
    OpSent {
        /// The op.
        name: Name,
        /// Whether this cluster issued it.
        issued_here: bool,
    },
    /// An unanswered op was sent again.
    OpResent {
        /// The op.
        name: Name,
        /// Where to.
        to: ClusterId,
    },
    /// An op this cluster sent was answered done.
    OpAnswered {
        /// The op.
        name: Name,
    },
    /// An op for an entity handed on since it was issued was taken on, to send once to the
    /// owner this cluster knows.
    OpForwarded {
        /// The op.
        name: Name,
        /// The owner it goes to.
        to: ClusterId,
    },
    /// An op for an entity this cluster does not own and could not forward: answered "not
    /// here".
    OpNotHere {
        /// The op.
        name: Name,
    },
    /// An op received again after it was closed here: answered, not applied again.
    OpRepeated {
        /// The op.
        name: Name,
    },
    /// An op was applied to a body this cluster owns.
    OpApplied {
        /// The op.
        name: Name,
        /// Its stage times.
        timing: OpTiming,
        /// The cluster its target was adopted from, if this cluster holds it as an adopter.
        adopted_from: Option<ClusterId>,
    },
    /// An op was dropped for good.
    OpDropped {
        /// The op.
        name: Name,
        /// Why.
        reason: OpDrop,
        /// For an op dropped as stale by its sender on finding its target its own now: the
        /// cluster the target was adopted from, if any.
        adopted_from: Option<ClusterId>,
    },
    /// Issuers whose closed numbers were forgotten to make room.
    OpWindowsForgotten {
        /// How many.
        count: u64,
    },
    /// A contact between a body of this cluster and a proxy was reported to the proxy's owner
    /// for the first time.
    ContactReported {
        /// The report.
        name: Name,
    },
    /// An unanswered contact report was sent again.
    ContactResent {
        /// The report.
        name: Name,
        /// Where to.
        to: ClusterId,
    },
    /// A contact report this cluster sent was answered.
    ContactAnswered {
        /// The report.
        name: Name,
    },
    /// A contact report was given up by its sender.
    ContactGivenUp {
        /// The report.
        name: Name,
        /// Why.
        reason: ContactGiveUp,
    },
    /// A contact report was received from a neighbour (repeats too).
    ContactReceived {
        /// The report.
        name: Name,
    },
    /// A contact report surfaced (or merged) here before came again: answered only.
    ContactRepeated {
        /// The report.
        name: Name,
    },
    /// A contact report too old to surface was dropped.
    ContactStale {
        /// The report.
        name: Name,
    },
    /// A contact report was taken: surfaced to game code, or merged with this world's copy.
    ContactDelivered {
        /// The report.
        name: Name,
        /// The cluster a body of the report is held for here as an adopter, if one is.
        adopted_from: Option<ClusterId>,
    },
    /// Contacts seen twice (here and in a neighbour's report) whose second copy was dropped.
    ContactsMerged {
        /// How many.
        count: u64,
    },
    /// What a contact across the seam gave a body of this cluster was sent to the other
    /// body's owner, to settle.
    SeamImpulseSent {
        /// The owner.
        to: ClusterId,
    },
    /// Such a report was received.
    SeamImpulseReceived,
    /// A received report named a body not simulated here, or carried a value beyond the bound.
    SeamImpulseDropped,
    /// A settling impulse was given to a body of this cluster.
    SeamImpulseSettled {
        /// The body.
        entity: EntityId,
    },
    /// Pairs whose two impulses disagreed too much to be one contact.
    SeamImpulsesDisagreed {
        /// How many.
        count: u64,
    },
    /// Impulses whose other half did not come in time.
    SeamImpulsesUnmatched {
        /// How many.
        count: u64,
    },
    /// A contact the other world did not see: its push went to the other body's owner as a
    /// routed impulse.
    SeamImpulseRouted {
        /// The owner.
        to: ClusterId,
    },
    /// An unmatched impulse whose other world had not published its reports of that step:
    /// nothing routed.
    SeamImpulseUnjudged,
    /// The authority policy asked for a hand-off, and it was queued.
    HandoffAsked {
        /// The entity.
        entity: EntityId,
        /// The new owner.
        to: ClusterId,
    },
    /// An entity was handed to a neighbour (its replication frame went out).
    HandoffGiven {
        /// The entity.
        entity: EntityId,
        /// The new owner.
        to: ClusterId,
    },
    /// An entity was taken over from a neighbour.
    HandoffTaken {
        /// The entity.
        entity: EntityId,
        /// The old owner.
        from: ClusterId,
        /// The first tick it is this cluster's: the one after the tick it was handed in, however
        /// late its frame came.
        since: u64,
    },
    /// A hand-off to a neighbour that left before taking it was taken back.
    HandoffTakenBack {
        /// The entity.
        entity: EntityId,
        /// The neighbour that left.
        from: ClusterId,
    },
    /// A hand-off a live neighbour did not take within `neighbour_timeout_ticks` came back.
    #[allow(missing_docs)]
    HandoffReturned { entity: EntityId, to: ClusterId },
    /// An entity owned here was claimed at a later epoch by its sender: this copy is its proxy.
    HandoffYielded {
        /// The entity.
        entity: EntityId,
        /// The cluster that claimed it back.
        to: ClusterId,
    },
    /// An adopted entity was yielded to a later claim (`HandoffYielded`): nothing to return.
    #[allow(missing_docs)]
    AdoptionYielded { entity: EntityId, from: ClusterId },
    /// A hand-off to a neighbour taken for dead before it took it was taken back.
    HandoffReclaimed {
        /// The entity.
        entity: EntityId,
        /// The neighbour taken for dead.
        from: ClusterId,
    },
    /// A neighbour silent past `neighbour_timeout_ticks` was taken for dead.
    NeighbourLost {
        /// The neighbour.
        neighbour: ClusterId,
    },
    /// A neighbour said it stops on purpose.
    NeighbourLeft {
        /// The neighbour.
        neighbour: ClusterId,
    },
    /// A neighbour taken for dead or left was heard from again.
    NeighbourRejoined {
        /// The neighbour.
        neighbour: ClusterId,
    },
    /// An entity of a neighbour taken for dead was adopted here.
    EntityAdopted {
        /// The entity.
        entity: EntityId,
        /// The neighbour.
        from: ClusterId,
    },
    /// An adopted entity is handed back to its owner, heard from again.
    EntityReturned {
        /// The entity.
        entity: EntityId,
        /// Its owner.
        to: ClusterId,
    },
}
