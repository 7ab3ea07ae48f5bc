//! The byte layout of a replication frame: header, tables and records, each a `Pod` of byte
//! arrays (alignment 1), and the body-spec table entry's encoding.

use bytemuck::{Pod, Zeroable};

use super::WireResult;
use crate::wire::{BodySpec, Groups, Material, Motion, Shape, ShapeId, WireError};

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
pub(super) struct Header {
    pub(super) version: u8,
    pub(super) encoding: u8,
    pub(super) owners: u8,
    pub(super) kind: u8,
    pub(super) specs: [u8; 2],
    pub(super) reserved2: [u8; 2],
    pub(super) tick: [u8; 8],
    pub(super) states: [u8; 4],
    pub(super) incarnation: [u8; 8],
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
pub(super) struct SpecRecord {
    pub(super) kind: u8,
    pub(super) flags: u8,
    pub(super) reserved: [u8; 2],
    pub(super) density: [u8; 4],
    pub(super) sizes: [u8; 12],
    /// Friction, restitution, linear and angular damping.
    pub(super) material: [u8; 16],
    /// Memberships, filter.
    pub(super) groups: [u8; 8],
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
pub(super) struct Identity {
    pub(super) id: [u8; 16],
    pub(super) epoch: [u8; 4],
    pub(super) age: [u8; 2],
    pub(super) owner: u8,
    pub(super) spec: [u8; 2],
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
pub(super) struct ExactRecord {
    pub(super) who: Identity,
    pub(super) position: [u8; 12],
    pub(super) rotation: [u8; 16],
    pub(super) linvel: [u8; 12],
    pub(super) angvel: [u8; 12],
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
pub(super) struct QuantizedRecord {
    pub(super) who: Identity,
    pub(super) position: [u8; 12],
    pub(super) rotation: [u8; 6],
    pub(super) linvel: [u8; 6],
    pub(super) angvel: [u8; 6],
}

/// What follows the tables of a delta frame: the keyframe it is read against, then a bitmap
/// of that keyframe's states still as they were.
#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
pub(super) struct DeltaHead {
    pub(super) key_tick: [u8; 8],
    pub(super) key_states: [u8; 4],
}

/// `Header::kind` of a frame that lists every state (a keyframe).
pub(super) const KIND_FULL: u8 = 0;
/// `Header::kind` of a frame read against a keyframe.
pub(super) const KIND_DELTA: u8 = 1;
pub(super) const DELTA_HEAD_LEN: usize = size_of::<DeltaHead>();

pub(super) const HEADER_LEN: usize = size_of::<Header>();
pub(super) const OWNER_LEN: usize = 16;
pub(super) const SPEC_LEN: usize = size_of::<SpecRecord>();
pub(super) const MAX_OWNERS: usize = u8::MAX as usize;
pub(super) const MAX_SPECS: usize = u16::MAX as usize;

const FLAG_CCD: u8 = 1;
const FLAG_SIMULATED: u8 = 2;
/// Moved by its owner through its velocity ([`Motion::Kinematic`]); never with
/// `FLAG_SIMULATED`. A spec with neither is [`Motion::Still`], as frames from before the flag
/// read.
const FLAG_KINEMATIC: u8 = 4;
/// A sensor.
const FLAG_SENSOR: u8 = 8;
/// `SpecRecord::kind` of a catalog shape: sizes hold its id (u64) and bound (f32).
const KIND_CATALOG: u8 = 3;

pub(super) fn malformed(what: impl Into<String>) -> WireError {
    WireError::Malformed(what.into())
}

pub(super) fn floats<const N: usize, const B: usize>(values: [f32; N]) -> [u8; B] {
    let mut bytes = [0u8; B];
    for (slot, value) in bytes.chunks_exact_mut(4).zip(values) {
        slot.copy_from_slice(&value.to_le_bytes());
    }
    bytes
}

pub(super) fn read_floats<const N: usize>(bytes: &[u8]) -> [f32; N] {
    let mut values = [0f32; N];
    for (value, b) in values.iter_mut().zip(bytes.chunks_exact(4)) {
        *value = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    }
    values
}

pub(super) fn spec_record(spec: &BodySpec) -> SpecRecord {
    let (kind, sizes) = match spec.shape {
        Shape::Ball { radius } => (0, floats([radius, 0.0, 0.0])),
        Shape::Cuboid { half_extents } => (1, floats(half_extents)),
        Shape::Capsule {
            half_height,
            radius,
        } => (2, floats([half_height, radius, 0.0])),
        Shape::Catalog { id, bound } => {
            let mut sizes = [0u8; 12];
            sizes[..8].copy_from_slice(&id.0.to_le_bytes());
            sizes[8..].copy_from_slice(&bound.to_le_bytes());
            (KIND_CATALOG, sizes)
        }
    };
    let motion = match spec.motion {
        Motion::Simulated => FLAG_SIMULATED,
        Motion::Kinematic => FLAG_KINEMATIC,
        Motion::Still => 0,
    };
    let flags =
        if spec.ccd { FLAG_CCD } else { 0 } | if spec.sensor { FLAG_SENSOR } else { 0 } | motion;
    let m = spec.material;
    let mut groups = [0u8; 8];
    groups[..4].copy_from_slice(&spec.groups.memberships.to_le_bytes());
    groups[4..].copy_from_slice(&spec.groups.filter.to_le_bytes());
    SpecRecord {
        kind,
        flags,
        reserved: [0; 2],
        density: spec.density.to_le_bytes(),
        sizes,
        material: floats([
            m.friction,
            m.restitution,
            m.linear_damping,
            m.angular_damping,
        ]),
        groups,
    }
}

pub(super) fn read_spec(record: &SpecRecord) -> WireResult<BodySpec> {
    let [a, b, c] = read_floats::<3>(&record.sizes);
    let shape = match record.kind {
        0 => Shape::Ball { radius: a },
        1 => Shape::Cuboid {
            half_extents: [a, b, c],
        },
        2 => Shape::Capsule {
            half_height: a,
            radius: b,
        },
        KIND_CATALOG => {
            let mut id = [0u8; 8];
            id.copy_from_slice(&record.sizes[..8]);
            Shape::Catalog {
                id: ShapeId(u64::from_le_bytes(id)),
                bound: c,
            }
        }
        kind => return Err(malformed(format!("unknown shape kind {kind}"))),
    };
    let motion = match (
        record.flags & FLAG_SIMULATED != 0,
        record.flags & FLAG_KINEMATIC != 0,
    ) {
        (true, false) => Motion::Simulated,
        (false, true) => Motion::Kinematic,
        (false, false) => Motion::Still,
        (true, true) => return Err(malformed("a body both simulated and kinematic")),
    };
    let [friction, restitution, linear_damping, angular_damping] = read_floats(&record.material);
    let word = |i: usize| {
        let b = &record.groups[i * 4..i * 4 + 4];
        u32::from_le_bytes([b[0], b[1], b[2], b[3]])
    };
    Ok(BodySpec {
        shape,
        density: f32::from_le_bytes(record.density),
        ccd: record.flags & FLAG_CCD != 0,
        motion,
        material: Material {
            friction,
            restitution,
            linear_damping,
            angular_damping,
        },
        groups: Groups {
            memberships: word(0),
            filter: word(1),
        },
        sensor: record.flags & FLAG_SENSOR != 0,
    })
}

/// Bit-exact key of a body spec, to share one table entry between equal specs.
pub(super) fn spec_key(spec: &BodySpec) -> [u8; SPEC_LEN] {
    let mut key = [0u8; SPEC_LEN];
    key.copy_from_slice(bytemuck::bytes_of(&spec_record(spec)));
    key
}
