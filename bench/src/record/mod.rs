//! Recordings of a run: what every cluster owned, proxied, applied and was told, tick by tick,
//! for `seam inspect` to draw.
//!
//! # Format (version 1)
//!
//! ```text
//! file   = "SEAMREC\0" | version: u16 LE | header length: u32 LE | header (JSON) | chunk*
//! chunk  = kind: u8 | body length: u32 LE | body
//! ```
//!
//! The header ([`Header`]) names the scene, its clusters and the *streams* (one per cluster, in
//! scene order, then `reference` for the single world of a `seam compare` recording), and lists
//! every entity the run can have as groups: each scene entity with its grid copies, then each
//! projectile shot the run's ticks allow. An entity is its index in that list everywhere else,
//! so every pod of a run numbers entities the same way without talking.
//!
//! Chunk kind 1, one stream's tick ([`StreamTick`]), all integers LEB128 varints (signed ones
//! zigzag):
//!
//! ```text
//! stream | tick | tick time µs
//! owned count    | per owned entity: index − previous index | x, y, z (mm) | heading: u8
//! proxy count    | per proxy: index − previous index
//! op count       | per routed op applied: sender stream + 1 (0: unknown) | target | ticks since issued
//! contact count  | per contact reported by a neighbour: a | b | started | reporter stream + 1
//! hand-off count | per hand-off taken or given in the tick: entity | taken (1) or given (0)
//! ```
//!
//! Positions are millimetres, written as the change since the entity's position in the
//! stream's previous chunk when it was owned there too, else whole. The heading is the rotation
//! about the vertical axis in 256 steps (the inspector looks from above), written for boxes
//! only: a ball or an upright capsule looks the same from above whichever way it turns, and is
//! written with heading 0. An owned entity costs
//! at most 21 bytes a tick (1–5 for its index, 1–5 per coordinate, 1 for heading); a resting
//! or slow body about 6.
//!
//! Chunk kind 2, a fault (`seam chaos`): `tick | stream + 1 (0: none) | text length | UTF-8`.
//!
//! Readers skip chunks of a kind they do not know, and stop at a chunk cut short (a pod killed
//! mid-write), counting it. Hand-offs are written as each side saw them, so one taken and given
//! back within a tick shows though the owner after the tick did not change; an owner change
//! with no hand-off written is an adoption (the old owner was taken for dead).

mod codec;
mod merge;
mod pod;
mod table;

use std::io::{Read, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::scene::SceneShape;
pub use codec::{ChunkDecoder, ChunkEncoder};
pub use merge::{MergeSummary, PartsDir, merge_parts, part_files};
pub use pod::PodRecorder;
pub use table::EntityTable;

/// The first bytes of every recording.
pub const MAGIC: &[u8; 8] = b"SEAMREC\0";
/// The format version this code writes and reads.
pub const VERSION: u16 = 1;
/// Chunk kind: one stream's tick.
pub const CHUNK_TICK: u8 = 1;
/// Chunk kind: a fault.
pub const CHUNK_FAULT: u8 = 2;
/// Largest chunk body a reader accepts, bytes (a 100 000-entity tick is ~2 MB).
pub const MAX_CHUNK: usize = 64 << 20;
/// Largest header a reader accepts, bytes.
pub const MAX_HEADER: usize = 64 << 20;

/// What a recording is of (the JSON header).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// The scene's name.
    pub scene: String,
    /// The command that recorded it (`seam run`, `seam compare`, `seam chaos`).
    pub source: String,
    /// The run id the pods shared.
    pub run_id: String,
    /// Step length, s.
    pub dt: f32,
    /// Ticks planned.
    pub ticks: u64,
    /// Ticks per second the pods ran at (0: as fast as they could, or lock-step).
    pub rate_hz: f64,
    /// The scene's clusters, in scene order.
    pub clusters: Vec<RecordedCluster>,
    /// Stream names: the clusters' in order, then `reference` when the single world is in it.
    pub streams: Vec<String>,
    /// Every entity the run can have, in groups of consecutive indices.
    pub groups: Vec<EntityGroup>,
    /// Poses of the scenery (loaded by every cluster, owned by none, never moves).
    pub scenery: Vec<ScenePose>,
    /// Number of entities (the sum of the groups' copies).
    pub entities: u32,
}

impl Header {
    /// The stream of the single world, if recorded.
    pub fn reference_stream(&self) -> Option<u16> {
        self.streams
            .iter()
            .position(|s| s == "reference")
            .map(|i| i as u16)
    }

    /// The group entity `index` belongs to.
    pub fn group_of(&self, index: u32) -> Option<&EntityGroup> {
        self.groups
            .iter()
            .find(|g| (g.first..g.first + g.copies).contains(&index))
    }

    /// The name of entity `index`: its group's, with `#i` for one of several copies.
    pub fn entity_name(&self, index: u32) -> String {
        match self.group_of(index) {
            Some(g) if g.copies > 1 => format!("{}#{}", g.name, index - g.first),
            Some(g) => g.name.clone(),
            None => format!("entity {index}"),
        }
    }

    /// The index of the entity named `name` (`group#i` or a group of one).
    pub fn entity_index(&self, name: &str) -> Option<u32> {
        let (group, copy) = match name.rsplit_once('#') {
            Some((g, i)) => (g, i.parse::<u32>().ok()?),
            None => (name, 0),
        };
        let g = self.groups.iter().find(|g| g.name == group)?;
        (copy < g.copies).then_some(g.first + copy)
    }
}

/// A cluster of the scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordedCluster {
    /// Its name.
    pub name: String,
    /// Its region's lower corner, m.
    pub min: [f32; 3],
    /// Its region's upper corner, m.
    pub max: [f32; 3],
    /// How far past the region it models neighbours, m.
    pub spread: f32,
    /// The host it ran on, if the scene names one.
    pub host: Option<String>,
}

/// Consecutive entities of one scene entry (a grid's copies) or one projectile event.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EntityGroup {
    /// The scene entity's name, or `projectile N` for scene event N.
    pub name: String,
    /// Index of the first copy.
    pub first: u32,
    /// Number of copies (shots, for a projectile event).
    pub copies: u32,
    /// Collision shape.
    pub shape: SceneShape,
    /// `dynamic`, `fixed`, `kinematic`, `scenery` or `projectile`.
    pub role: String,
}

/// Where a static entity stands.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScenePose {
    /// The entity.
    pub entity: u32,
    /// Position, m.
    pub position: [f32; 3],
    /// Rotation about the vertical axis, 256 steps to a turn.
    pub heading: u8,
}

/// One stream's tick (chunk kind 1).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StreamTick {
    /// The stream.
    pub stream: u16,
    /// The world's tick count after the step.
    pub tick: u64,
    /// How long the tick took, µs.
    pub tick_us: u32,
    /// What the stream owned after the step, by entity index.
    pub owned: Vec<OwnedPose>,
    /// Entities it held a proxy of, ascending.
    pub proxies: Vec<u32>,
    /// Routed ops it applied in the tick.
    pub ops: Vec<RecordedOp>,
    /// Contacts neighbours reported to it in the tick.
    pub contacts: Vec<RecordedContact>,
    /// Hand-offs it took or gave in the tick, in order.
    pub handoffs: Vec<RecordedHandoff>,
}

/// A hand-off one side saw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordedHandoff {
    /// The entity.
    pub entity: u32,
    /// Taken by the stream (else given away).
    pub taken: bool,
}

/// An owned entity's pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OwnedPose {
    /// The entity.
    pub entity: u32,
    /// Position, mm.
    pub mm: [i32; 3],
    /// Rotation about the vertical axis, 256 steps to a turn.
    pub heading: u8,
}

impl OwnedPose {
    /// Position, m.
    pub fn position(&self) -> [f32; 3] {
        self.mm.map(|v| v as f32 / 1000.0)
    }
}

/// A routed op applied by its owner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordedOp {
    /// The stream whose frame brought it (`None`: not a cluster of the scene).
    pub from: Option<u16>,
    /// The entity written to.
    pub target: u32,
    /// Ticks between the write and its application.
    pub ticks_late: u64,
}

/// A contact a neighbour reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordedContact {
    /// One entity.
    pub a: u32,
    /// The other.
    pub b: u32,
    /// Started (else stopped).
    pub started: bool,
    /// The stream that reported it (`None`: not a cluster of the scene).
    pub reporter: Option<u16>,
}

/// Something done to the run from outside (chunk kind 2).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Fault {
    /// About when (the run's tick).
    pub tick: u64,
    /// The stream it was done to, if one.
    pub stream: Option<u16>,
    /// What.
    pub what: String,
}

/// A chunk of a recording.
#[derive(Debug, Clone, PartialEq)]
pub enum Chunk {
    /// One stream's tick.
    Tick(StreamTick),
    /// A fault.
    Fault(Fault),
}

impl Chunk {
    /// Its tick.
    pub fn tick(&self) -> u64 {
        match self {
            Chunk::Tick(t) => t.tick,
            Chunk::Fault(f) => f.tick,
        }
    }
}

/// Why a recording could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// Reading or writing failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// Not a recording.
    #[error("not a seam recording (no SEAMREC header)")]
    NotARecording,
    /// Written by another version.
    #[error("recording format version {0}; this seam reads version {VERSION}")]
    Version(u16),
    /// The header does not parse.
    #[error("recording header: {0}")]
    Header(String),
    /// It holds no tick to show.
    #[error("the recording has no ticks")]
    Empty,
    /// A chunk does not parse.
    #[error("recording chunk at tick {tick:?}: {why}")]
    Chunk {
        /// Its tick, if read.
        tick: Option<u64>,
        /// What is wrong.
        why: String,
    },
}

/// Heading of a rotation `[x, y, z, w]`: the angle of its x axis in the x–z plane, 256 steps
/// to a turn (`atan2(z, x)`, the way a view from above with z down the screen turns).
pub fn heading(q: [f32; 4]) -> u8 {
    let [x, y, z, w] = q;
    let fx = 1.0 - 2.0 * (y * y + z * z);
    let fz = 2.0 * (x * z - w * y);
    let turns = fz.atan2(fx) / std::f32::consts::TAU;
    (turns * 256.0).round().rem_euclid(256.0) as u8
}

/// Writes the file header.
pub fn write_header(out: &mut impl Write, header: &Header) -> Result<(), RecordError> {
    let json = serde_json::to_vec(header).map_err(|e| RecordError::Header(e.to_string()))?;
    out.write_all(MAGIC)?;
    out.write_all(&VERSION.to_le_bytes())?;
    out.write_all(&(json.len() as u32).to_le_bytes())?;
    out.write_all(&json)?;
    Ok(())
}

/// Reads the file header; `input` is then at the first chunk.
pub fn read_header(input: &mut impl Read) -> Result<Header, RecordError> {
    let mut magic = [0u8; 8];
    input
        .read_exact(&mut magic)
        .map_err(|_| RecordError::NotARecording)?;
    if &magic != MAGIC {
        return Err(RecordError::NotARecording);
    }
    let mut word = [0u8; 2];
    input.read_exact(&mut word)?;
    let version = u16::from_le_bytes(word);
    if version != VERSION {
        return Err(RecordError::Version(version));
    }
    let mut len = [0u8; 4];
    input.read_exact(&mut len)?;
    let len = u32::from_le_bytes(len) as usize;
    if len > MAX_HEADER {
        return Err(RecordError::Header(format!("{len} bytes, too long")));
    }
    let mut json = vec![0u8; len];
    input.read_exact(&mut json)?;
    serde_json::from_slice(&json).map_err(|e| RecordError::Header(e.to_string()))
}

/// A whole recording in memory.
#[derive(Debug, Clone)]
pub struct Recording {
    /// Its header.
    pub header: Header,
    /// Its chunks, in file order.
    pub chunks: Vec<Chunk>,
    /// Chunks of unknown kind skipped.
    pub skipped: u64,
    /// Whether the file ended inside a chunk (a pod stopped mid-write).
    pub cut_short: bool,
}

impl Recording {
    /// Reads the recording at `path`.
    pub fn read(path: &Path) -> Result<Self, RecordError> {
        let bytes = std::fs::read(path)?;
        Self::parse(&bytes)
    }

    /// Reads a recording from its bytes.
    pub fn parse(bytes: &[u8]) -> Result<Self, RecordError> {
        let mut input = bytes;
        let header = read_header(&mut input)?;
        let mut decoder = ChunkDecoder::new(&header);
        let mut chunks = Vec::new();
        while let Some(chunk) = decoder.next_chunk(&mut input)? {
            chunks.push(chunk);
        }
        Ok(Self {
            header,
            chunks,
            skipped: decoder.skipped,
            cut_short: decoder.cut_short,
        })
    }

    /// The ticks of stream `stream`, in order.
    pub fn stream_ticks(&self, stream: u16) -> impl Iterator<Item = &StreamTick> {
        self.chunks.iter().filter_map(move |c| match c {
            Chunk::Tick(t) if t.stream == stream => Some(t),
            _ => None,
        })
    }

    /// Which stream owned entity `index` at `tick` (the first that did).
    pub fn owner_at(&self, index: u32, tick: u64) -> Option<u16> {
        let reference = self.header.reference_stream();
        self.chunks.iter().find_map(|c| match c {
            Chunk::Tick(t)
                if t.tick == tick
                    && Some(t.stream) != reference
                    && t.owned.binary_search_by_key(&index, |p| p.entity).is_ok() =>
            {
                Some(t.stream)
            }
            _ => None,
        })
    }
}

#[cfg(test)]
mod tests;
