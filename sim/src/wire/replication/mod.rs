//! The replication frame's wire form: fixed-layout records a receiver validates and reads in
//! place, with no decode pass.
//!
//! ```text
//! header   28 bytes   version, encoding, owner count (u8), kind (u8: 0 full, 1 delta),
//!                     spec count (u16), 0 0, tick (u64), state count (u32), the
//!                     publisher's incarnation (u64)
//! owners   16 bytes each   the owner table; the first is the publisher
//! specs    44 bytes each   the body-spec table (shape kind, flags, 0 0, density, 3 sizes or a
//!                         catalog id (u64) and bound, friction, restitution, linear and
//!                         angular damping, collision memberships and filter (u32 each))
//! delta    delta frames only: the keyframe's tick (u64) and state count (u32), then one bit
//!          per keyframe state, set where that state is unchanged
//! states   77 bytes each (exact) or 55 (quantized)
//! ```
//!
//! A full frame (a keyframe) lists every state. A delta frame lists only the states that
//! changed since its keyframe and marks the keyframe's others unchanged ([`DeltaBase`]); an
//! entity that neither lists is gone. A receiver holding the keyframe reads the two together.
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

mod encoder;
mod layout;
mod quantize;
mod view;

pub use encoder::ReplicationEncoder;
pub use quantize::{MAX_QUANTIZED_VELOCITY, POSITION_STEPS_PER_METRE};
pub use view::ReplicationView;

use layout::{ExactRecord, HEADER_LEN, MAX_OWNERS, OWNER_LEN, QuantizedRecord, SPEC_LEN};

use super::{ReplicationFrame, WireError};

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

/// What a delta frame is read against: the keyframe it follows, and which of that keyframe's
/// states are unchanged — as the keyframe listed them, and still this frame's news. A state a
/// delta frame lists overrides the keyframe's; an entity neither lists is gone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeltaBase<'a> {
    /// The keyframe's tick.
    pub key_tick: u64,
    /// How many states the keyframe listed.
    pub key_states: u32,
    /// One bit per keyframe state, least significant first: bit `j % 8` of byte `j / 8` set
    /// when state `j` is unchanged.
    pub unchanged: &'a [u8],
}

impl DeltaBase<'_> {
    /// Bytes of the bitmap.
    pub fn bitmap_len(&self) -> usize {
        bitmap_len(self.key_states)
    }

    /// Whether the keyframe's state `j` is unchanged (`false` past the bitmap).
    pub fn is_unchanged(&self, j: usize) -> bool {
        j < self.key_states as usize
            && self
                .unchanged
                .get(j / 8)
                .is_some_and(|byte| byte & (1 << (j % 8)) != 0)
    }

    /// How many of the keyframe's states are unchanged.
    pub fn unchanged_count(&self) -> usize {
        (0..self.key_states as usize)
            .filter(|&j| self.is_unchanged(j))
            .count()
    }
}

/// Bytes of a bitmap of `states` bits.
fn bitmap_len(states: u32) -> usize {
    (states as usize).div_ceil(8)
}

/// Most bytes one state adds to a frame: an exact record and a spec of its own.
pub const MAX_STATE_LEN: usize = size_of::<ExactRecord>() + SPEC_LEN;

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
    /// receiver that wants to keep the good ones reads a [`ReplicationView`]). Of a delta
    /// frame, only the states it lists (its keyframe's unchanged ones are not in `bytes`).
    pub fn decode(bytes: &[u8]) -> WireResult<Self> {
        let view = ReplicationView::parse(bytes)?;
        Ok(Self {
            from: view.from(),
            tick: view.tick(),
            incarnation: view.incarnation(),
            states: view.states().collect::<WireResult<_>>()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_have_the_documented_sizes() {
        assert_eq!(HEADER_LEN, 28);
        assert_eq!(SPEC_LEN, 44);
        assert_eq!(StateEncoding::Exact.record_len(), 77);
        assert_eq!(StateEncoding::Quantized.record_len(), 55);
    }
}
