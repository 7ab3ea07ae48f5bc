//! The wire: what clusters send each other, each frame behind a format version byte.
//!
//! Replication frames, a tick's worth of entity states, are fixed-layout records a receiver
//! validates and reads in place ([`ReplicationView`], laid out in `replication/`); events
//! frames (routed ops, contacts, impulses) are postcard. Decoding takes untrusted bytes: it
//! returns a [`WireError`] rather than panicking, rejects trailing bytes, and grows lists only as
//! elements actually decode, so a forged length cannot make it allocate more than the input
//! justifies.

mod build;
mod codec;
mod events;
mod ids;
mod replication;
mod state;

pub use ids::{ClusterId, EntityId, IdHasher, IdMap};
pub use replication::{
    DeltaBase, MAX_QUANTIZED_VELOCITY, MAX_STATE_LEN, POSITION_STEPS_PER_METRE, ReplicationEncoder,
    ReplicationView, StateEncoding,
};

pub use codec::{WireError, decode, encode, encode_into, encoded_len};
pub use events::{
    ContactReport, OpAck, PhysicsEventsFrame, PhysicsOp, RoutedOp, SeamImpulseReport, Stage,
};
pub use state::{
    BodySpec, EntityState, Groups, Material, Motion, ReplicationFrame, Shape, ShapeId,
};

/// The format version every frame starts with.
pub const WIRE_VERSION: u8 = 11;
