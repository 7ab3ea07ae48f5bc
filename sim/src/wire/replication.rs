//! The replication frame's wire form: fixed-layout records a receiver validates and reads in
//! place, with no decode pass.
//!
//! ```text
//! header   20 bytes   version, encoding, owner count (u8), 0, spec count (u16), 0 0, tick (u64),
//!                     state count (u32)
//! owners   16 bytes each   the owner table; the first is the publisher
//! specs    20 bytes each   the body-spec table (shape kind, flags, 0 0, density, 3 sizes)
//! states   77 bytes each (exact) or 55 (quantized)
//! ```
//!
//! A state record names its entity (16 bytes), its authority epoch (u32), how many ticks
//! before the frame's tick it is from (u16, saturating), its owner and body spec as indices
//! into the frame's tables (u8, u16), then its motion. Exact motion is 13 `f32`s. Quantized
//! motion is the position in fixed point ([`POSITION_STEPS_PER_METRE`]: ±0.49 mm, to
//! ±2 097 km), the rotation as its smallest three components (15 bits each, ≤ 2·10⁻⁴ rad), and
//! both velocities as IEEE half floats (relative error ≤ 2⁻¹¹, bounded to ±65 504). Every
//! number is little-endian; every record field is a byte array, so records have alignment 1
//! and a received buffer is viewed as records wherever it starts ([`bytemuck`] does the
//! casting; seam has no `unsafe`).
//!
//! A [`ReplicationView`] checks the header, the table sizes and the total length when it is
//! made; a record whose owner or spec index is out of its table, whose spec is of an unknown
//! kind or whose rotation is not a unit quaternion is an error when that record is read, so a
//! receiver counts it and reads the rest.

use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use half::f16;
use uuid::Uuid;

use super::{
    BodySpec, ClusterId, EntityId, EntityState, ReplicationFrame, Shape, WIRE_VERSION, WireError,
};

type WireResult<T> = Result<T, WireError>;

/// How a replication frame writes motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StateEncoding {
    /// 13 `f32`s, bit for bit what the owner's world holds (77 bytes a state).
    #[default]
    Exact,
    /// Fixed-point position, smallest-three rotation, half-float velocities (55 bytes a
    /// state): at most 0.49 mm of position and 2·10⁻⁴ rad of rotation off.
    Quantized,
}

impl StateEncoding {
    fn tag(self) -> u8 {
        match self {
            StateEncoding::Exact => 0,
            StateEncoding::Quantized => 1,
        }
    }

    /// Bytes of one state record.
    pub fn record_len(self) -> usize {
        match self {
            StateEncoding::Exact => size_of::<ExactRecord>(),
            StateEncoding::Quantized => size_of::<QuantizedRecord>(),
        }
    }
}

/// Fixed-point steps per metre of a quantized position.
pub const POSITION_STEPS_PER_METRE: f32 = 1024.0;

/// Largest velocity component a quantized frame carries (the largest finite half float);
/// larger ones are clamped to it.
pub const MAX_QUANTIZED_VELOCITY: f32 = 65504.0;

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct Header {
    version: u8,
    encoding: u8,
    owners: u8,
    reserved: u8,
    specs: [u8; 2],
    reserved2: [u8; 2],
    tick: [u8; 8],
    states: [u8; 4],
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct SpecRecord {
    kind: u8,
    flags: u8,
    reserved: [u8; 2],
    density: [u8; 4],
    sizes: [u8; 12],
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct Identity {
    id: [u8; 16],
    epoch: [u8; 4],
    age: [u8; 2],
    owner: u8,
    spec: [u8; 2],
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct ExactRecord {
    who: Identity,
    position: [u8; 12],
    rotation: [u8; 16],
    linvel: [u8; 12],
    angvel: [u8; 12],
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct QuantizedRecord {
    who: Identity,
    position: [u8; 12],
    rotation: [u8; 6],
    linvel: [u8; 6],
    angvel: [u8; 6],
}

const HEADER_LEN: usize = size_of::<Header>();
const OWNER_LEN: usize = 16;
const SPEC_LEN: usize = size_of::<SpecRecord>();
const MAX_OWNERS: usize = u8::MAX as usize;
const MAX_SPECS: usize = u16::MAX as usize;

/// Most bytes one state adds to a frame: an exact record and a spec of its own.
pub const MAX_STATE_LEN: usize = size_of::<ExactRecord>() + SPEC_LEN;

const FLAG_CCD: u8 = 1;
const FLAG_SIMULATED: u8 = 2;

fn malformed(what: impl Into<String>) -> WireError {
    WireError::Malformed(what.into())
}

fn floats<const N: usize, const B: usize>(values: [f32; N]) -> [u8; B] {
    let mut bytes = [0u8; B];
    for (slot, value) in bytes.chunks_exact_mut(4).zip(values) {
        slot.copy_from_slice(&value.to_le_bytes());
    }
    bytes
}

fn read_floats<const N: usize>(bytes: &[u8]) -> [f32; N] {
    let mut values = [0f32; N];
    for (value, b) in values.iter_mut().zip(bytes.chunks_exact(4)) {
        *value = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    }
    values
}

fn spec_record(spec: &BodySpec) -> SpecRecord {
    let (kind, sizes) = match spec.shape {
        Shape::Ball { radius } => (0, [radius, 0.0, 0.0]),
        Shape::Cuboid { half_extents } => (1, half_extents),
        Shape::Capsule {
            half_height,
            radius,
        } => (2, [half_height, radius, 0.0]),
    };
    let flags =
        if spec.ccd { FLAG_CCD } else { 0 } | if spec.simulated { FLAG_SIMULATED } else { 0 };
    SpecRecord {
        kind,
        flags,
        reserved: [0; 2],
        density: spec.density.to_le_bytes(),
        sizes: floats(sizes),
    }
}

fn read_spec(record: &SpecRecord) -> WireResult<BodySpec> {
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
        kind => return Err(malformed(format!("unknown shape kind {kind}"))),
    };
    Ok(BodySpec {
        shape,
        density: f32::from_le_bytes(record.density),
        ccd: record.flags & FLAG_CCD != 0,
        simulated: record.flags & FLAG_SIMULATED != 0,
    })
}

/// Bit-exact key of a body spec, to share one table entry between equal specs.
fn spec_key(spec: &BodySpec) -> [u8; SPEC_LEN] {
    bytemuck::cast(spec_record(spec))
}

fn quantize_position(position: [f32; 3]) -> [u8; 12] {
    let mut bytes = [0u8; 12];
    for (slot, x) in bytes.chunks_exact_mut(4).zip(position) {
        // `as` saturates at the i32 range (and sends NaN to 0).
        let steps = (x * POSITION_STEPS_PER_METRE).round() as i32;
        slot.copy_from_slice(&steps.to_le_bytes());
    }
    bytes
}

fn read_position(bytes: &[u8; 12]) -> [f32; 3] {
    let mut position = [0f32; 3];
    for (x, b) in position.iter_mut().zip(bytes.chunks_exact(4)) {
        *x = i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32 / POSITION_STEPS_PER_METRE;
    }
    position
}

const ROTATION_STEPS: f32 = 16383.0;

/// Smallest three: the index of the largest component (2 bits), then the other three, each
/// within ±1/√2, in 15 bits each; the sign is chosen so the largest is positive.
fn quantize_rotation(rotation: [f32; 4]) -> [u8; 6] {
    let norm = rotation.iter().map(|c| c * c).sum::<f32>().sqrt();
    let q = if norm.is_finite() && norm > 0.0 {
        rotation.map(|c| c / norm)
    } else {
        [0.0, 0.0, 0.0, 1.0]
    };
    let largest = (0..4)
        .max_by(|&a, &b| q[a].abs().total_cmp(&q[b].abs()))
        .unwrap_or(3);
    let sign = if q[largest] < 0.0 { -1.0 } else { 1.0 };
    let mut bits = (largest as u64) << 45;
    let mut shift = 30;
    for (i, &c) in q.iter().enumerate() {
        if i == largest {
            continue;
        }
        let scaled = (c * sign * std::f32::consts::SQRT_2).clamp(-1.0, 1.0);
        let step = ((scaled * ROTATION_STEPS).round() + ROTATION_STEPS) as u64;
        bits |= step << shift;
        shift -= 15;
    }
    let mut bytes = [0u8; 6];
    bytes.copy_from_slice(&bits.to_le_bytes()[..6]);
    bytes
}

fn read_rotation(bytes: &[u8; 6]) -> WireResult<[f32; 4]> {
    let mut eight = [0u8; 8];
    eight[..6].copy_from_slice(bytes);
    let bits = u64::from_le_bytes(eight);
    let largest = ((bits >> 45) & 3) as usize;
    let mut q = [0f32; 4];
    let mut shift = 30;
    let mut sum = 0.0;
    for (i, c) in q.iter_mut().enumerate() {
        if i == largest {
            continue;
        }
        let step = ((bits >> shift) & 0x7fff) as f32;
        *c = (step - ROTATION_STEPS) / ROTATION_STEPS / std::f32::consts::SQRT_2;
        sum += *c * *c;
        shift -= 15;
    }
    if bits >> 47 != 0 || sum > 1.0 {
        return Err(malformed("rotation is not a unit quaternion"));
    }
    // Unit by construction, to f32 rounding.
    q[largest] = (1.0 - sum).sqrt();
    Ok(q)
}

fn halves(values: [f32; 3]) -> [u8; 6] {
    let mut bytes = [0u8; 6];
    for (slot, v) in bytes.chunks_exact_mut(2).zip(values) {
        let bounded = v.clamp(-MAX_QUANTIZED_VELOCITY, MAX_QUANTIZED_VELOCITY);
        slot.copy_from_slice(&f16::from_f32(bounded).to_le_bytes());
    }
    bytes
}

fn read_halves(bytes: &[u8; 6]) -> [f32; 3] {
    let mut values = [0f32; 3];
    for (v, b) in values.iter_mut().zip(bytes.chunks_exact(2)) {
        *v = half_to_f32(u16::from_le_bytes([b[0], b[1]]));
    }
    values
}

/// An IEEE 754 binary16 as f32 (exact: every half is an f32). Written out rather than through
/// `half`, whose portable conversion is a call per value: a receiver reads six a state.
#[inline]
fn half_to_f32(bits: u16) -> f32 {
    let sign = u32::from(bits & 0x8000) << 16;
    let exponent = u32::from(bits >> 10) & 0x1f;
    let mantissa = u32::from(bits & 0x3ff);
    match exponent {
        // Zero and subnormals: mantissa × 2⁻²⁴.
        0 => {
            let magnitude = mantissa as f32 * (1.0 / 16_777_216.0);
            f32::from_bits(sign | magnitude.to_bits())
        }
        // Infinity and NaN.
        0x1f => f32::from_bits(sign | 0x7f80_0000 | (mantissa << 13)),
        // Normal: rebias the exponent from 15 to 127.
        _ => f32::from_bits(sign | ((exponent + 112) << 23) | (mantissa << 13)),
    }
}

/// Reusable tables for encoding replication frames: keep one per publisher so steady-state
/// publishing reuses their memory.
#[derive(Debug, Default)]
pub struct ReplicationEncoder {
    owners: Vec<ClusterId>,
    specs: Vec<[u8; SPEC_LEN]>,
    spec_index: HashMap<[u8; SPEC_LEN], u16>,
    /// Per state: owner index, spec index.
    indices: Vec<(u8, u16)>,
    encoding: StateEncoding,
}

impl ReplicationEncoder {
    /// Builds the owner and spec tables of `frame` and returns its encoded length. Fails if
    /// the frame names more than 255 owners or 65 535 distinct body specs.
    pub fn prepare(
        &mut self,
        frame: &ReplicationFrame,
        encoding: StateEncoding,
    ) -> WireResult<usize> {
        self.encoding = encoding;
        self.owners.clear();
        self.owners.push(frame.from);
        self.specs.clear();
        self.spec_index.clear();
        self.indices.clear();
        // Neighbouring states mostly share owner and spec: the last ones are tried first.
        let mut last_owner = 0;
        let mut last_spec: Option<(BodySpec, u16)> = None;
        for state in &frame.states {
            let owner = if self.owners[last_owner] == state.cluster_id {
                last_owner
            } else {
                match self.owners.iter().position(|&o| o == state.cluster_id) {
                    Some(i) => i,
                    None if self.owners.len() < MAX_OWNERS => {
                        self.owners.push(state.cluster_id);
                        self.owners.len() - 1
                    }
                    None => return Err(malformed("a frame names at most 255 owners")),
                }
            };
            last_owner = owner;
            let spec = match last_spec {
                Some((last, i)) if last == state.body => i,
                _ => {
                    let i = self.spec_of(&state.body)?;
                    last_spec = Some((state.body, i));
                    i
                }
            };
            self.indices.push((owner as u8, spec));
        }
        Ok(self.len(frame.states.len()))
    }

    /// Encoded length of a frame of `states` states with the tables as prepared.
    fn len(&self, states: usize) -> usize {
        HEADER_LEN
            + self.owners.len() * OWNER_LEN
            + self.specs.len() * SPEC_LEN
            + states * self.encoding.record_len()
    }

    /// The table index of `spec`, added if new: a scan while the table is short (most frames
    /// hold a few specs), a hash lookup beyond.
    fn spec_of(&mut self, spec: &BodySpec) -> WireResult<u16> {
        const SCANNED: usize = 16;
        let key = spec_key(spec);
        let next = self.specs.len();
        let found = if next <= SCANNED {
            self.specs.iter().position(|k| *k == key).map(|i| i as u16)
        } else {
            self.spec_index.get(&key).copied()
        };
        if let Some(i) = found {
            return Ok(i);
        }
        if next == MAX_SPECS {
            return Err(malformed("a frame holds at most 65 535 body specs"));
        }
        self.specs.push(key);
        if next == SCANNED {
            // The table outgrows the scan: index everything so far.
            self.spec_index = self
                .specs
                .iter()
                .enumerate()
                .map(|(i, k)| (*k, i as u16))
                .collect();
        } else if next > SCANNED {
            self.spec_index.insert(key, next as u16);
        }
        Ok(next as u16)
    }

    /// Writes `frame`, which [`Self::prepare`] was last given, to the start of `buffer`;
    /// returns the bytes written.
    pub fn write(&self, frame: &ReplicationFrame, buffer: &mut [u8]) -> WireResult<usize> {
        let encoding = self.encoding;
        let len = self.len(frame.states.len());
        if self.indices.len() != frame.states.len() {
            return Err(malformed("the encoder was prepared for another frame"));
        }
        if buffer.len() < len {
            return Err(WireError::BufferTooSmall {
                needed: len,
                capacity: buffer.len(),
            });
        }
        let (head, rest) = buffer[..len].split_at_mut(HEADER_LEN);
        let header = Header {
            version: WIRE_VERSION,
            encoding: encoding.tag(),
            owners: self.owners.len() as u8,
            reserved: 0,
            specs: (self.specs.len() as u16).to_le_bytes(),
            reserved2: [0; 2],
            tick: frame.tick.to_le_bytes(),
            states: (frame.states.len() as u32).to_le_bytes(),
        };
        head.copy_from_slice(bytemuck::bytes_of(&header));
        let (owners, rest) = rest.split_at_mut(self.owners.len() * OWNER_LEN);
        for (slot, owner) in owners.chunks_exact_mut(OWNER_LEN).zip(&self.owners) {
            slot.copy_from_slice(owner.0.as_bytes());
        }
        let (specs, records) = rest.split_at_mut(self.specs.len() * SPEC_LEN);
        for (slot, spec) in specs.chunks_exact_mut(SPEC_LEN).zip(&self.specs) {
            slot.copy_from_slice(spec);
        }
        let identity = |state: &EntityState, &(owner, spec): &(u8, u16)| Identity {
            id: *state.id.0.as_bytes(),
            epoch: state.epoch.to_le_bytes(),
            age: (frame
                .tick
                .saturating_sub(state.tick)
                .min(u64::from(u16::MAX)) as u16)
                .to_le_bytes(),
            owner,
            spec: spec.to_le_bytes(),
        };
        let states = frame.states.iter().zip(&self.indices);
        match encoding {
            StateEncoding::Exact => {
                let records: &mut [ExactRecord] = bytemuck::cast_slice_mut(records);
                for (record, (state, indices)) in records.iter_mut().zip(states) {
                    *record = ExactRecord {
                        who: identity(state, indices),
                        position: floats(state.position),
                        rotation: floats(state.rotation),
                        linvel: floats(state.linvel),
                        angvel: floats(state.angvel),
                    };
                }
            }
            StateEncoding::Quantized => {
                let records: &mut [QuantizedRecord] = bytemuck::cast_slice_mut(records);
                for (record, (state, indices)) in records.iter_mut().zip(states) {
                    *record = QuantizedRecord {
                        who: identity(state, indices),
                        position: quantize_position(state.position),
                        rotation: quantize_rotation(state.rotation),
                        linvel: halves(state.linvel),
                        angvel: halves(state.angvel),
                    };
                }
            }
        }
        Ok(len)
    }
}

#[derive(Clone, Copy)]
enum Records<'a> {
    Exact(&'a [ExactRecord]),
    Quantized(&'a [QuantizedRecord]),
}

/// A received replication frame, read in place: the header and sizes are checked when it is
/// made, each state when it is read.
#[derive(Clone, Copy)]
pub struct ReplicationView<'a> {
    tick: u64,
    owners: &'a [[u8; OWNER_LEN]],
    specs: &'a [SpecRecord],
    records: Records<'a>,
}

impl std::fmt::Debug for ReplicationView<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReplicationView")
            .field("from", &self.from())
            .field("tick", &self.tick)
            .field("states", &self.len())
            .field("encoding", &self.encoding())
            .finish()
    }
}

impl<'a> ReplicationView<'a> {
    /// Checks the version, header and sizes of untrusted `bytes`.
    pub fn parse(bytes: &'a [u8]) -> WireResult<Self> {
        let (&version, _) = bytes.split_first().ok_or(WireError::Empty)?;
        if version != WIRE_VERSION {
            return Err(WireError::Version { found: version });
        }
        let head = bytes
            .get(..HEADER_LEN)
            .ok_or_else(|| malformed("shorter than a replication header"))?;
        let header: Header = bytemuck::pod_read_unaligned(head);
        let encoding = match header.encoding {
            0 => StateEncoding::Exact,
            1 => StateEncoding::Quantized,
            other => return Err(malformed(format!("unknown state encoding {other}"))),
        };
        let owners = usize::from(header.owners);
        if owners == 0 {
            return Err(malformed("no publisher in the owner table"));
        }
        let specs = usize::from(u16::from_le_bytes(header.specs));
        let states = u32::from_le_bytes(header.states) as usize;
        let needed = states
            .checked_mul(encoding.record_len())
            .and_then(|n| n.checked_add(HEADER_LEN + owners * OWNER_LEN + specs * SPEC_LEN))
            .ok_or_else(|| malformed("state count overflows"))?;
        if bytes.len() < needed {
            return Err(malformed(format!(
                "{} bytes where the header promises {needed}",
                bytes.len()
            )));
        }
        if bytes.len() > needed {
            return Err(WireError::TrailingBytes(bytes.len() - needed));
        }
        let rest = &bytes[HEADER_LEN..];
        let (owner_bytes, rest) = rest.split_at(owners * OWNER_LEN);
        let (spec_bytes, record_bytes) = rest.split_at(specs * SPEC_LEN);
        let cast = |e: bytemuck::PodCastError| malformed(format!("{e:?}"));
        let records = match encoding {
            StateEncoding::Exact => {
                Records::Exact(bytemuck::try_cast_slice(record_bytes).map_err(cast)?)
            }
            StateEncoding::Quantized => {
                Records::Quantized(bytemuck::try_cast_slice(record_bytes).map_err(cast)?)
            }
        };
        Ok(Self {
            tick: u64::from_le_bytes(header.tick),
            owners: bytemuck::try_cast_slice(owner_bytes).map_err(cast)?,
            specs: bytemuck::try_cast_slice(spec_bytes).map_err(cast)?,
            records,
        })
    }

    /// The publisher.
    pub fn from(&self) -> ClusterId {
        ClusterId(Uuid::from_bytes(self.owners[0]))
    }

    /// The publisher's tick.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// How the frame writes motion.
    pub fn encoding(&self) -> StateEncoding {
        match self.records {
            Records::Exact(_) => StateEncoding::Exact,
            Records::Quantized(_) => StateEncoding::Quantized,
        }
    }

    /// How many states the frame holds.
    pub fn len(&self) -> usize {
        match self.records {
            Records::Exact(r) => r.len(),
            Records::Quantized(r) => r.len(),
        }
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn identity(&self, i: usize) -> Option<&'a Identity> {
        match self.records {
            Records::Exact(r) => r.get(i).map(|r| &r.who),
            Records::Quantized(r) => r.get(i).map(|r| &r.who),
        }
    }

    /// The entity of state `i`, read without the rest of the record.
    pub fn id(&self, i: usize) -> Option<EntityId> {
        self.identity(i)
            .map(|who| EntityId(Uuid::from_bytes(who.id)))
    }

    /// Whether state `i` names an owner other than the publisher (a hand-off), read without
    /// the rest of the record.
    pub fn hands_off(&self, i: usize) -> bool {
        self.identity(i).is_some_and(|who| who.owner != 0)
    }

    /// State `i`, read and checked against the frame's tables.
    pub fn state(&self, i: usize) -> WireResult<EntityState> {
        let who = self
            .identity(i)
            .ok_or_else(|| malformed(format!("no state {i}")))?;
        let owner = self
            .owners
            .get(usize::from(who.owner))
            .ok_or_else(|| malformed(format!("owner {} is not in the table", who.owner)))?;
        let spec_at = usize::from(u16::from_le_bytes(who.spec));
        let body = read_spec(
            self.specs
                .get(spec_at)
                .ok_or_else(|| malformed(format!("body spec {spec_at} is not in the table")))?,
        )?;
        let (position, rotation, linvel, angvel) = match self.records {
            Records::Exact(r) => {
                let r = &r[i];
                (
                    read_floats(&r.position),
                    read_floats(&r.rotation),
                    read_floats(&r.linvel),
                    read_floats(&r.angvel),
                )
            }
            Records::Quantized(r) => {
                let r = &r[i];
                (
                    read_position(&r.position),
                    read_rotation(&r.rotation)?,
                    read_halves(&r.linvel),
                    read_halves(&r.angvel),
                )
            }
        };
        Ok(EntityState {
            id: EntityId(Uuid::from_bytes(who.id)),
            cluster_id: ClusterId(Uuid::from_bytes(*owner)),
            tick: self
                .tick
                .saturating_sub(u64::from(u16::from_le_bytes(who.age))),
            epoch: u32::from_le_bytes(who.epoch),
            position,
            rotation,
            linvel,
            angvel,
            body,
        })
    }

    /// Every state, in order, each read and checked.
    pub fn states(&self) -> impl Iterator<Item = WireResult<EntityState>> + '_ {
        (0..self.len()).map(|i| self.state(i))
    }
}

impl ReplicationFrame {
    /// Encoded size in `encoding`.
    pub fn encoded_len(&self, encoding: StateEncoding) -> WireResult<usize> {
        ReplicationEncoder::default().prepare(self, encoding)
    }

    /// An upper bound of the encoded size in any encoding, without building tables: size a
    /// transport buffer with it.
    pub fn max_encoded_len(&self) -> usize {
        HEADER_LEN + MAX_OWNERS * OWNER_LEN + self.states.len() * MAX_STATE_LEN
    }

    /// Encodes the frame into a new buffer.
    pub fn encode(&self, encoding: StateEncoding) -> WireResult<Vec<u8>> {
        let mut encoder = ReplicationEncoder::default();
        let mut buffer = vec![0; encoder.prepare(self, encoding)?];
        encoder.write(self, &mut buffer)?;
        Ok(buffer)
    }

    /// Encodes the frame into the start of `buffer`; returns the bytes written.
    pub fn encode_into(&self, encoding: StateEncoding, buffer: &mut [u8]) -> WireResult<usize> {
        let mut encoder = ReplicationEncoder::default();
        encoder.prepare(self, encoding)?;
        encoder.write(self, buffer)
    }

    /// Decodes every state of untrusted `bytes`; any bad record fails the whole frame (a
    /// receiver that wants to keep the good ones reads a [`ReplicationView`]).
    pub fn decode(bytes: &[u8]) -> WireResult<Self> {
        let view = ReplicationView::parse(bytes)?;
        Ok(Self {
            from: view.from(),
            tick: view.tick(),
            states: view.states().collect::<WireResult<_>>()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_have_the_documented_sizes() {
        assert_eq!(HEADER_LEN, 20);
        assert_eq!(SPEC_LEN, 20);
        assert_eq!(StateEncoding::Exact.record_len(), 77);
        assert_eq!(StateEncoding::Quantized.record_len(), 55);
    }

    /// Rotation angle between two unit quaternions, from their difference: the arc cosine of
    /// their dot product, at f32 precision, makes ~7e-4 rad of nothing.
    pub(super) fn angle_between(a: [f32; 4], b: [f32; 4]) -> f32 {
        let sign = if a.iter().zip(&b).map(|(x, y)| x * y).sum::<f32>() < 0.0 {
            -1.0
        } else {
            1.0
        };
        let d = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - sign * y).powi(2))
            .sum::<f32>();
        4.0 * (d.sqrt() / 2.0).asin()
    }

    #[test]
    fn smallest_three_round_trips_within_two_ten_thousandths_of_a_radian() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..10_000 {
            let q = [next(), next(), next(), next()];
            let norm = q.iter().map(|c| c * c).sum::<f32>().sqrt();
            let q = q.map(|c| c / norm);
            let back = read_rotation(&quantize_rotation(q)).expect("a unit quaternion");
            let angle = angle_between(q, back);
            assert!(angle < 2e-4, "{q:?} came back as {back:?}: {angle} rad off");
        }
    }

    #[test]
    fn every_half_float_reads_as_the_half_crate_reads_it() {
        for bits in 0..=u16::MAX {
            let ours = half_to_f32(bits);
            let theirs = f16::from_bits(bits).to_f32();
            assert!(
                ours.to_bits() == theirs.to_bits() || (ours.is_nan() && theirs.is_nan()),
                "{bits:#06x}: {ours} against {theirs}"
            );
        }
    }

    #[test]
    fn positions_round_trip_within_half_a_step() {
        for x in [0.0, 0.000_49, -1.5, 123.456_7, -4_000.25, 999_999.0] {
            let [back, ..] = read_position(&quantize_position([x, 0.0, 0.0]));
            // Past a few thousand metres the f32 itself is coarser than the step.
            let tolerance = 0.5 / POSITION_STEPS_PER_METRE + x.abs() * f32::EPSILON;
            assert!((back - x).abs() <= tolerance, "{x} came back as {back}");
        }
    }
}
