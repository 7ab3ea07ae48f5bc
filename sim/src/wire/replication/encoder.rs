//! Writing a replication frame: the owner and body-spec tables, then the records.

use std::collections::HashMap;

use super::layout::{
    DELTA_HEAD_LEN, DeltaHead, ExactRecord, HEADER_LEN, Header, Identity, KIND_DELTA, KIND_FULL,
    MAX_OWNERS, MAX_SPECS, OWNER_LEN, QuantizedRecord, SPEC_LEN, floats, malformed, spec_key,
};
use super::quantize::{halves, quantize_position, quantize_rotation};
use super::{DeltaBase, StateEncoding, WireResult};
use crate::wire::{BodySpec, ClusterId, EntityState, ReplicationFrame, WIRE_VERSION, WireError};

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
    /// For a delta frame: the keyframe's tick and state count, and the unchanged bitmap.
    delta: Option<(u64, u32)>,
    unchanged: Vec<u8>,
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
        self.delta = None;
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

    /// As [`Self::prepare`], for a delta frame: `frame` lists only the states that are not
    /// among `base`'s unchanged ones. Fails if the bitmap is shorter than the keyframe's
    /// state count needs.
    pub fn prepare_delta(
        &mut self,
        frame: &ReplicationFrame,
        encoding: StateEncoding,
        base: DeltaBase<'_>,
    ) -> WireResult<usize> {
        let bitmap = base.bitmap_len();
        if base.unchanged.len() < bitmap {
            return Err(malformed(
                "the unchanged bitmap is shorter than the keyframe",
            ));
        }
        self.prepare(frame, encoding)?;
        self.delta = Some((base.key_tick, base.key_states));
        self.unchanged.clear();
        self.unchanged.extend_from_slice(&base.unchanged[..bitmap]);
        Ok(self.len(frame.states.len()))
    }

    /// Encoded length of a frame of `states` states with the tables as prepared.
    fn len(&self, states: usize) -> usize {
        let delta = self
            .delta
            .map_or(0, |_| DELTA_HEAD_LEN + self.unchanged.len());
        HEADER_LEN
            + self.owners.len() * OWNER_LEN
            + self.specs.len() * SPEC_LEN
            + delta
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
        head.copy_from_slice(bytemuck::bytes_of(&self.header(frame)));
        let records = self.write_tables(rest);
        self.write_records(frame, records);
        Ok(len)
    }

    fn header(&self, frame: &ReplicationFrame) -> Header {
        Header {
            version: WIRE_VERSION,
            encoding: self.encoding.tag(),
            owners: self.owners.len() as u8,
            kind: if self.delta.is_some() {
                KIND_DELTA
            } else {
                KIND_FULL
            },
            specs: (self.specs.len() as u16).to_le_bytes(),
            reserved2: [0; 2],
            tick: frame.tick.to_le_bytes(),
            states: (frame.states.len() as u32).to_le_bytes(),
            incarnation: frame.incarnation.to_le_bytes(),
        }
    }

    /// Writes the owner and spec tables (and a delta frame's head and bitmap) to the start of
    /// `rest`; returns what follows them, the records' room.
    fn write_tables<'b>(&self, rest: &'b mut [u8]) -> &'b mut [u8] {
        let (owners, rest) = rest.split_at_mut(self.owners.len() * OWNER_LEN);
        for (slot, owner) in owners.chunks_exact_mut(OWNER_LEN).zip(&self.owners) {
            slot.copy_from_slice(owner.0.as_bytes());
        }
        let (specs, rest) = rest.split_at_mut(self.specs.len() * SPEC_LEN);
        for (slot, spec) in specs.chunks_exact_mut(SPEC_LEN).zip(&self.specs) {
            slot.copy_from_slice(spec);
        }
        match self.delta {
            Some((key_tick, key_states)) => {
                let (head, rest) = rest.split_at_mut(DELTA_HEAD_LEN);
                head.copy_from_slice(bytemuck::bytes_of(&DeltaHead {
                    key_tick: key_tick.to_le_bytes(),
                    key_states: key_states.to_le_bytes(),
                }));
                let (bitmap, records) = rest.split_at_mut(self.unchanged.len());
                bitmap.copy_from_slice(&self.unchanged);
                records
            }
            None => rest,
        }
    }

    /// Writes the frame's records, in the encoding prepared, into `records`.
    fn write_records(&self, frame: &ReplicationFrame, records: &mut [u8]) {
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
        match self.encoding {
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
    }
}
