//! The wire form of [`EntityState`]: the fixed-size part (ids, pose, velocities) as one byte
//! block, then the tick, the authority epoch and the body descriptor as ordinary postcard
//! fields.
//!
//! A frame of 10 000 states is mostly these blocks; moving each as one slice instead of ~40
//! separate serde fields is what keeps encoding plus decoding of such a frame under a
//! millisecond. Floats are little-endian IEEE 754, ids their 16 UUID bytes.

use serde::de::{self, SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use uuid::Uuid;

use super::{BodySpec, ClusterId, EntityId, EntityState};

/// Bytes of the fixed-size block: two ids and 13 floats.
const BLOCK: usize = 16 + 16 + 13 * 4;

fn block_of(state: &EntityState) -> [u8; BLOCK] {
    let mut block = [0u8; BLOCK];
    block[..16].copy_from_slice(state.id.0.as_bytes());
    block[16..32].copy_from_slice(state.cluster_id.0.as_bytes());
    let floats = state
        .position
        .iter()
        .chain(&state.rotation)
        .chain(&state.linvel)
        .chain(&state.angvel);
    for (slot, value) in block[32..].chunks_exact_mut(4).zip(floats) {
        slot.copy_from_slice(&value.to_le_bytes());
    }
    block
}

struct Block<'a>(&'a [u8; BLOCK]);

impl Serialize for Block<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_bytes(self.0)
    }
}

impl Serialize for EntityState {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut tuple = serializer.serialize_tuple(4)?;
        tuple.serialize_element(&Block(&block_of(self)))?;
        tuple.serialize_element(&self.tick)?;
        tuple.serialize_element(&self.epoch)?;
        tuple.serialize_element(&self.body)?;
        tuple.end()
    }
}

/// The block, read back from the bytes the deserializer hands over.
struct ReadBlock([u8; BLOCK]);

impl<'de> Deserialize<'de> for ReadBlock {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct BlockVisitor;
        impl<'de> Visitor<'de> for BlockVisitor {
            type Value = ReadBlock;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{BLOCK} bytes of entity motion")
            }
            fn visit_bytes<E: de::Error>(self, bytes: &[u8]) -> Result<ReadBlock, E> {
                <[u8; BLOCK]>::try_from(bytes)
                    .map(ReadBlock)
                    .map_err(|_| E::invalid_length(bytes.len(), &self))
            }
        }
        deserializer.deserialize_bytes(BlockVisitor)
    }
}

impl<'de> Deserialize<'de> for EntityState {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct StateVisitor;
        impl<'de> Visitor<'de> for StateVisitor {
            type Value = EntityState;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("an entity state")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<EntityState, A::Error> {
                let missing = |i| de::Error::invalid_length(i, &"4 fields");
                let ReadBlock(block) = seq.next_element()?.ok_or_else(|| missing(0))?;
                let tick: u64 = seq.next_element()?.ok_or_else(|| missing(1))?;
                let epoch: u32 = seq.next_element()?.ok_or_else(|| missing(2))?;
                let body: BodySpec = seq.next_element()?.ok_or_else(|| missing(3))?;
                let id = |at: usize| {
                    let mut bytes = [0u8; 16];
                    bytes.copy_from_slice(&block[at..at + 16]);
                    Uuid::from_bytes(bytes)
                };
                let mut floats = [0f32; 13];
                for (value, bytes) in floats.iter_mut().zip(block[32..].chunks_exact(4)) {
                    *value = f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
                }
                let three = |at: usize| [floats[at], floats[at + 1], floats[at + 2]];
                Ok(EntityState {
                    id: EntityId(id(0)),
                    cluster_id: ClusterId(id(16)),
                    tick,
                    epoch,
                    position: three(0),
                    rotation: [floats[3], floats[4], floats[5], floats[6]],
                    linvel: three(7),
                    angvel: three(10),
                    body,
                })
            }
        }
        deserializer.deserialize_tuple(4, StateVisitor)
    }
}
