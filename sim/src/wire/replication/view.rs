//! Reading a received replication frame in place.

use uuid::Uuid;

use super::layout::{
    DELTA_HEAD_LEN, DeltaHead, ExactRecord, HEADER_LEN, Header, Identity, KIND_DELTA, KIND_FULL,
    OWNER_LEN, QuantizedRecord, SPEC_LEN, SpecRecord, malformed, read_floats, read_spec,
};
use super::quantize::{read_halves, read_position, read_rotation};
use super::{DeltaBase, StateEncoding, WireResult, bitmap_len};
use crate::wire::{ClusterId, EntityId, EntityState, WIRE_VERSION, WireError};

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
    incarnation: u64,
    owners: &'a [[u8; OWNER_LEN]],
    specs: &'a [SpecRecord],
    records: Records<'a>,
    delta: Option<DeltaBase<'a>>,
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
        let tables = HEADER_LEN + owners * OWNER_LEN + specs * SPEC_LEN;
        let delta_len = match header.kind {
            KIND_FULL => 0,
            KIND_DELTA => {
                let head = bytes
                    .get(tables..tables + DELTA_HEAD_LEN)
                    .ok_or_else(|| malformed("shorter than its delta header"))?;
                let head: DeltaHead = bytemuck::pod_read_unaligned(head);
                DELTA_HEAD_LEN + bitmap_len(u32::from_le_bytes(head.key_states))
            }
            other => return Err(malformed(format!("unknown frame kind {other}"))),
        };
        let needed = states
            .checked_mul(encoding.record_len())
            .and_then(|n| n.checked_add(tables + delta_len))
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
        let (spec_bytes, rest) = rest.split_at(specs * SPEC_LEN);
        let (delta_bytes, record_bytes) = rest.split_at(delta_len);
        let delta = (header.kind == KIND_DELTA).then(|| {
            let (head, unchanged) = delta_bytes.split_at(DELTA_HEAD_LEN);
            let head: DeltaHead = bytemuck::pod_read_unaligned(head);
            DeltaBase {
                key_tick: u64::from_le_bytes(head.key_tick),
                key_states: u32::from_le_bytes(head.key_states),
                unchanged,
            }
        });
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
            incarnation: u64::from_le_bytes(header.incarnation),
            owners: bytemuck::try_cast_slice(owner_bytes).map_err(cast)?,
            specs: bytemuck::try_cast_slice(spec_bytes).map_err(cast)?,
            records,
            delta,
        })
    }

    /// For a delta frame, the keyframe it is read against and which of that keyframe's states
    /// still hold; `None` for a frame that lists every state (a keyframe).
    pub fn delta(&self) -> Option<DeltaBase<'a>> {
        self.delta
    }

    /// The publisher.
    pub fn from(&self) -> ClusterId {
        ClusterId(Uuid::from_bytes(self.owners[0]))
    }

    /// The publisher's tick.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// The publishing pod's incarnation (see [`ReplicationFrame::incarnation`](crate::wire::ReplicationFrame::incarnation)).
    pub fn incarnation(&self) -> u64 {
        self.incarnation
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
