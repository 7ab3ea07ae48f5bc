//! The wire: what clusters send each other, each frame behind a format version byte.
//!
//! Replication frames, a tick's worth of entity states, are fixed-layout records a receiver
//! validates and reads in place ([`ReplicationView`], laid out in `replication/`); events
//! frames (routed ops, contacts, impulses) are postcard. Decoding takes untrusted bytes: it
//! returns a [`WireError`] rather than panicking, rejects trailing bytes, and grows lists only as
//! elements actually decode, so a forged length cannot make it allocate more than the input
//! justifies.

mod build;
mod ids;
mod replication;

pub use ids::{ClusterId, EntityId, IdHasher, IdMap};
pub use replication::{
    DeltaBase, MAX_QUANTIZED_VELOCITY, MAX_STATE_LEN, POSITION_STEPS_PER_METRE, ReplicationEncoder,
    ReplicationView, StateEncoding,
};

use serde::de::{DeserializeOwned, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};

/// The format version every frame starts with.
pub const WIRE_VERSION: u8 = 7;

/// A collision shape, as small as a proxy needs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Shape {
    /// A sphere.
    Ball {
        /// Radius in metres.
        radius: f32,
    },
    /// A box.
    Cuboid {
        /// Half the size along x, y, z, in metres.
        half_extents: [f32; 3],
    },
    /// A capsule along the local y axis.
    Capsule {
        /// Half the length of the straight part, in metres.
        half_height: f32,
        /// Radius in metres.
        radius: f32,
    },
}

/// The spec of the body an entity is, beyond its pose: shape, density, whether it needs
/// continuous collision detection, and whether its owner simulates it. It travels with every state so a cluster that takes authority over an
/// entity simulates it with the same mass and CCD as the previous owner.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BodySpec {
    /// The collision shape.
    pub shape: Shape,
    /// Density in kg/m³ (mass = density × volume).
    pub density: f32,
    /// Continuous collision detection, for fast bodies that must not tunnel through thin ones.
    pub ccd: bool,
    /// Whether its authority simulates it as a dynamic body (`false` for Fixed and kinematic
    /// bodies its owner moves itself). Only a proxy of a simulated entity takes part in
    /// contacts with the entity's mass (see `seam_sim::coupling`); an adopter or new owner
    /// gives the body back the role it had.
    pub simulated: bool,
}

/// One entity's replicated state: the spine every neighbour receives. Its wire form is a
/// fixed-layout record (see [`ReplicationView`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EntityState {
    /// The entity.
    pub id: EntityId,
    /// The entity's **owner** (its authority): the cluster that simulates it and applies writes
    /// on it. The design and its users know the field as `cluster_id`, so the wire keeps the
    /// name; it never means the cluster holding the state. Changing it moves the entity.
    pub cluster_id: ClusterId,
    /// The authority's tick this state is from.
    pub tick: u64,
    /// How many times the entity's authority has moved: each hand-off increments it. A state
    /// older than what a cluster knows of the entity (a hand-off repeated after the entity
    /// moved on) is not news and changes nothing.
    pub epoch: u32,
    /// World position of the body origin, metres.
    pub position: [f32; 3],
    /// Orientation as a unit quaternion `[x, y, z, w]`.
    pub rotation: [f32; 4],
    /// Linear velocity, m/s.
    pub linvel: [f32; 3],
    /// Angular velocity, rad/s.
    pub angvel: [f32; 3],
    /// Shape, density, CCD.
    pub body: BodySpec,
}

impl EntityState {
    /// The entity's owner (the wire's `cluster_id`).
    pub fn owner(&self) -> ClusterId {
        self.cluster_id
    }

    /// Position, rotation, linear and angular velocity as raw IEEE 754 bits, to compare worlds
    /// exactly (determinism checks).
    pub fn motion_bits(&self) -> [u32; 13] {
        let mut bits = [0u32; 13];
        let values = self
            .position
            .iter()
            .chain(&self.rotation)
            .chain(&self.linvel)
            .chain(&self.angvel);
        for (slot, value) in bits.iter_mut().zip(values) {
            *slot = value.to_bits();
        }
        bits
    }
}

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

/// What one cluster publishes on `replication:<cluster_id>` each tick. Its wire form is
/// fixed-layout records read in place (see [`ReplicationView`]), not postcard.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplicationFrame {
    /// The publishing cluster.
    pub from: ClusterId,
    /// Its tick.
    pub tick: u64,
    /// The states of the entities it owns (and, in the tick of a hand-off, the entity it gives
    /// away, already naming its new authority).
    pub states: Vec<EntityState>,
}

/// What one cluster sends on `physics_events:<destination>` each tick.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhysicsEventsFrame {
    /// The sending cluster.
    pub from: ClusterId,
    /// Its tick.
    pub tick: u64,
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
    /// The sender stops on purpose after this frame: it is not to be taken for dead, and what
    /// it owns leaves with it (see `seam_proxy::Cluster::leave`).
    pub leaving: bool,
}

/// Why bytes are not a frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum WireError {
    /// No bytes at all.
    #[error("empty frame")]
    Empty,
    /// The frame is of another format version.
    #[error("frame format version {found}, this build reads version {WIRE_VERSION}")]
    Version {
        /// The version byte found.
        found: u8,
    },
    /// The body does not decode.
    #[error("malformed frame: {0}")]
    Malformed(String),
    /// The body decodes but bytes are left over.
    #[error("{0} bytes after the end of the frame")]
    TrailingBytes(usize),
    /// The destination buffer is too small.
    #[error("frame needs {needed} bytes, the buffer has {capacity}")]
    BufferTooSmall {
        /// Encoded size.
        needed: usize,
        /// Buffer size.
        capacity: usize,
    },
}

/// Deserializes a list by pushing elements as they decode: a declared length that the input
/// cannot back is never used to preallocate.
fn grow_as_decoded<'de, D, T>(deserializer: D) -> Result<Vec<T>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct Grow<T>(std::marker::PhantomData<T>);
    impl<'de, T: Deserialize<'de>> Visitor<'de> for Grow<T> {
        type Value = Vec<T>;
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("a list")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
            let mut items = Vec::new();
            while let Some(item) = seq.next_element()? {
                items.push(item);
            }
            Ok(items)
        }
    }
    deserializer.deserialize_seq(Grow(std::marker::PhantomData))
}

/// Encoded size of `frame` in bytes, version byte included.
pub fn encoded_len<T: Serialize>(frame: &T) -> usize {
    1 + postcard::serialize_with_flavor(frame, postcard::ser_flavors::Size::default()).unwrap_or(0)
}

/// Encodes `frame` into the start of `buffer` (for example a loaned shared-memory sample);
/// returns the bytes written. The frame is walked once; its size is worked out only when it
/// does not fit.
pub fn encode_into<T: Serialize>(frame: &T, buffer: &mut [u8]) -> Result<usize, WireError> {
    let too_small = |buffer: &[u8]| WireError::BufferTooSmall {
        needed: encoded_len(frame),
        capacity: buffer.len(),
    };
    let Some((version, rest)) = buffer.split_first_mut() else {
        return Err(too_small(buffer));
    };
    *version = WIRE_VERSION;
    match postcard::to_slice(frame, rest) {
        Ok(body) => Ok(1 + body.len()),
        Err(postcard::Error::SerializeBufferFull) => Err(too_small(buffer)),
        Err(e) => Err(WireError::Malformed(e.to_string())),
    }
}

/// Encodes `frame` into a new buffer.
pub fn encode<T: Serialize>(frame: &T) -> Vec<u8> {
    let mut buffer = vec![0; encoded_len(frame)];
    let written = encode_into(frame, &mut buffer).unwrap_or(0);
    buffer.truncate(written);
    buffer
}

/// Decodes a frame from untrusted bytes.
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, WireError> {
    let (&version, body) = bytes.split_first().ok_or(WireError::Empty)?;
    if version != WIRE_VERSION {
        return Err(WireError::Version { found: version });
    }
    let (frame, rest) =
        postcard::take_from_bytes(body).map_err(|e| WireError::Malformed(e.to_string()))?;
    if !rest.is_empty() {
        return Err(WireError::TrailingBytes(rest.len()));
    }
    Ok(frame)
}
