//! What physics-events frames carry: routed ops ([`PhysicsOp`], [`RoutedOp`]), their answers
//! ([`OpAck`]), contact reports and seam impulses, in a [`PhysicsEventsFrame`].

use serde::{Deserialize, Serialize};

use super::codec::grow_as_decoded;
use super::ids::{ClusterId, EntityId};

/// A write on an entity, routed to its authority when it is owned elsewhere.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum PhysicsOp {
    /// Add an impulse (N·s) at the centre of mass.
    Impulse {
        /// The entity.
        target: EntityId,
        /// Impulse vector.
        impulse: [f32; 3],
    },
    /// Add a force (N) for the next step.
    Force {
        /// The entity.
        target: EntityId,
        /// Force vector.
        force: [f32; 3],
    },
    /// Add an angular impulse (N·m·s).
    TorqueImpulse {
        /// The entity.
        target: EntityId,
        /// Angular impulse vector.
        torque_impulse: [f32; 3],
    },
    /// Teleport the body.
    SetTranslation {
        /// The entity.
        target: EntityId,
        /// New position, metres.
        translation: [f32; 3],
    },
    /// Set the linear velocity.
    SetLinvel {
        /// The entity.
        target: EntityId,
        /// New linear velocity, m/s.
        linvel: [f32; 3],
    },
    /// Set the angular velocity.
    SetAngvel {
        /// The entity.
        target: EntityId,
        /// New angular velocity, rad/s.
        angvel: [f32; 3],
    },
    /// Wake the body up.
    Wake {
        /// The entity.
        target: EntityId,
    },
    /// Put the body to sleep.
    Sleep {
        /// The entity.
        target: EntityId,
    },
}

impl PhysicsOp {
    /// The entity the op writes to.
    pub fn target(&self) -> EntityId {
        match *self {
            PhysicsOp::Impulse { target, .. }
            | PhysicsOp::Force { target, .. }
            | PhysicsOp::TorqueImpulse { target, .. }
            | PhysicsOp::SetTranslation { target, .. }
            | PhysicsOp::SetLinvel { target, .. }
            | PhysicsOp::SetAngvel { target, .. }
            | PhysicsOp::Wake { target }
            | PhysicsOp::Sleep { target } => target,
        }
    }

    /// The op's vector, if it carries one.
    pub fn vector(&self) -> Option<[f32; 3]> {
        match *self {
            PhysicsOp::Impulse { impulse: v, .. }
            | PhysicsOp::Force { force: v, .. }
            | PhysicsOp::TorqueImpulse {
                torque_impulse: v, ..
            }
            | PhysicsOp::SetTranslation { translation: v, .. }
            | PhysicsOp::SetLinvel { linvel: v, .. }
            | PhysicsOp::SetAngvel { angvel: v, .. } => Some(v),
            PhysicsOp::Wake { .. } | PhysicsOp::Sleep { .. } => None,
        }
    }

    /// The op's name, for errors and counters.
    pub fn name(&self) -> &'static str {
        match self {
            PhysicsOp::Impulse { .. } => "impulse",
            PhysicsOp::Force { .. } => "force",
            PhysicsOp::TorqueImpulse { .. } => "torque impulse",
            PhysicsOp::SetTranslation { .. } => "set translation",
            PhysicsOp::SetLinvel { .. } => "set linvel",
            PhysicsOp::SetAngvel { .. } => "set angvel",
            PhysicsOp::Wake { .. } => "wake",
            PhysicsOp::Sleep { .. } => "sleep",
        }
    }
}

/// A write on its way to the entity's owner, with when it was issued.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RoutedOp {
    /// The write.
    pub op: PhysicsOp,
    /// The issuer's number for it: with the issuer, what names the op everywhere it goes (an
    /// owner applies each name once, and acknowledges it by that name; see [`OpAck`]).
    pub seq: u64,
    /// The cluster whose game code issued it, when that is not the frame's sender: an op sent
    /// on by a cluster that no longer owned the target, to the owner it knew. `None`: the
    /// sender issued it. An op is forwarded at most once; one that misses again goes back.
    pub issuer: Option<ClusterId>,
    /// When user code made the write: nanoseconds of the host's monotonic clock (shared by
    /// every process of one host; meaningless across hosts).
    pub issued_ns: u64,
    /// The issuing cluster's tick when it made the write.
    pub issued_tick: u64,
    /// Ticks the op has spent in clusters' hands before this send, each counted on the
    /// clock of the cluster holding it (the issuer from the write to this send; a forwarder
    /// from receipt to forwarding): its age without assuming clusters share a tick count.
    pub age_ticks: u32,
}

impl OpAck {
    /// The numbers the answer covers.
    pub fn seqs(&self) -> std::ops::RangeInclusive<u64> {
        self.seq..=self.seq.saturating_add(u64::from(self.more))
    }
}

impl RoutedOp {
    /// Whether a cluster other than the frame's sender issued it (it was forwarded).
    pub fn forwarded(&self) -> bool {
        self.issuer.is_some()
    }
}

/// A receiver's answer to routed ops and contact reports, in its next events frame to their
/// sender: one answer for a run of consecutive numbers of one issuer (a batch of ops is
/// answered in a few bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct OpAck {
    /// The first op's number ([`RoutedOp::seq`]).
    pub seq: u64,
    /// How many consecutive numbers from `seq` the answer covers, less one.
    pub more: u16,
    /// Its issuer when that is not the frame's destination (the destination forwarded it).
    pub issuer: Option<ClusterId>,
    /// `true`: settled here — applied, or dropped for good (too old, invalid, a repeat of one
    /// settled before), or taken on to forward; the sender forgets it. `false`: not owned here
    /// and not forwarded; the sender sends it where it now knows the target to be.
    pub done: bool,
}

/// A contact that started or stopped between two entities, reported to the owner of the
/// entity the reporter does not own. Delivered like a routed op: numbered, answered
/// ([`OpAck`]), sent again until answered, surfaced once.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContactReport {
    /// The reporter's number for it, from the counter that numbers its ops (a receiver
    /// surfaces each number once and answers it by that number).
    pub seq: u64,
    /// Ticks since the reporter's step saw it, on the reporter's clock, before this send.
    pub age_ticks: u32,
    /// One entity of the pair.
    pub a: EntityId,
    /// The other.
    pub b: EntityId,
    /// `true` when the contact started, `false` when it stopped.
    pub started: bool,
    /// The reporting cluster's tick whose step saw the change.
    pub tick: u64,
    /// The impulse the contact gave `b` in the step it started, N·s (see
    /// `seam_sim::ContactEvent`).
    pub impulse: [f32; 3],
    /// The contact normal, from `a` to `b`.
    pub normal: [f32; 3],
}

/// What a contact across the seam gave the sender's body in one step: the receiver, which owns
/// the other body, keeps half of the difference between the two worlds' impulses (see
/// `seam_proxy`'s `settle`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SeamImpulseReport {
    /// The sender's body.
    pub own: EntityId,
    /// The receiver's entity it touched (a coupled proxy in the sender's world).
    pub other: EntityId,
    /// The impulse the contact gave `own`, N·s.
    pub impulse: [f32; 3],
    /// The sender's tick whose step it was.
    pub tick: u64,
}

/// When in its sender's tick a [`PhysicsEventsFrame`] was published.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Stage {
    /// After the step, tagged with the tick the step reached: answers, contact reports, seam
    /// impulses, and ops that missed the exchange (forwarded, sent again).
    #[default]
    AfterStep,
    /// Before the step (the exchange), tagged with the tick being run: the ops game code wrote
    /// this tick on the destination's entities, for it to apply in the same step, and the
    /// writes game code made on the sender's own bodies, for the destination's proxies of them.
    BeforeStep,
}

/// What one cluster sends on `physics_events:<destination>`: each tick one frame before its
/// step and one after (see [`Stage`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhysicsEventsFrame {
    /// The sending cluster.
    pub from: ClusterId,
    /// Its tick: the tick being run before the step, the tick reached after it.
    pub tick: u64,
    /// Before or after the sender's step.
    pub stage: Stage,
    /// When the frame was handed to the transport: host monotonic clock, nanoseconds.
    pub published_ns: u64,
    /// Writes on entities the destination owns.
    #[serde(deserialize_with = "grow_as_decoded")]
    pub ops: Vec<RoutedOp>,
    /// Answers to the ops and contact reports the destination sent the sender.
    #[serde(deserialize_with = "grow_as_decoded")]
    pub acks: Vec<OpAck>,
    /// Contacts between the sender's bodies and its proxies of the destination's entities.
    #[serde(deserialize_with = "grow_as_decoded")]
    pub contacts: Vec<ContactReport>,
    /// What touching contacts between the sender's bodies and its coupled proxies of the
    /// destination's entities gave the sender's bodies in its last step.
    #[serde(deserialize_with = "grow_as_decoded")]
    pub impulses: Vec<SeamImpulseReport>,
    /// Writes game code made this tick on the sender's own bodies (before the step only): the
    /// destination shows them on its coupled proxies of those bodies, so both worlds step
    /// them pushed.
    #[serde(deserialize_with = "grow_as_decoded")]
    pub own_writes: Vec<PhysicsOp>,
    /// The sender stops on purpose after this frame: it is not to be taken for dead, and what
    /// it owns leaves with it (see `seam_proxy::Cluster::leave`).
    pub leaving: bool,
    /// The destination's entities whose states the sender refused this tick because it cannot
    /// model them (a catalog shape it has not registered): the destination hands them nowhere
    /// near the sender (see `seam_proxy::Cluster::transfer_authority`).
    #[serde(deserialize_with = "grow_as_decoded")]
    pub unmodelled: Vec<EntityId>,
    /// The sending pod's incarnation, as in [`ReplicationFrame::incarnation`](super::ReplicationFrame::incarnation).
    pub incarnation: u64,
}

impl PhysicsEventsFrame {
    /// A frame from `from` at `tick`, at `stage`, published at `published_ns`, carrying
    /// nothing yet.
    pub fn empty(from: ClusterId, tick: u64, stage: Stage, published_ns: u64) -> Self {
        Self {
            from,
            tick,
            stage,
            published_ns,
            ops: Vec::new(),
            acks: Vec::new(),
            contacts: Vec::new(),
            impulses: Vec::new(),
            own_writes: Vec::new(),
            leaving: false,
            unmodelled: Vec::new(),
            incarnation: 0,
        }
    }
}
