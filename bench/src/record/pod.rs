//! A pod writing its own stream, tick by tick.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use seam_proxy::ClusterEvent;
use seam_sim::wire::ClusterId;

use super::{
    Chunk, ChunkEncoder, EntityTable, OwnedPose, RecordError, RecordedContact, RecordedHandoff,
    RecordedOp, StreamTick, heading, write_header,
};
use crate::pod::Pod;

/// `metres` to the nearest millimetre (saturating; NaN is 0), without a call to `roundf`.
fn millimetres(metres: f32) -> i32 {
    let mm = metres * 1000.0;
    (mm + 0.5f32.copysign(mm)) as i32
}

/// How often a recorder hands what it buffered to the file, so a live reader sees it.
const FLUSH_EVERY: Duration = Duration::from_millis(200);

/// Records the stream of one pod (or, with [`PodRecorder::observe`] called for several pods,
/// theirs) into a writer.
pub struct PodRecorder<W: Write = BufWriter<File>> {
    out: W,
    table: EntityTable,
    encoder: ChunkEncoder,
    chunk: StreamTick,
    /// Bytes written, header included.
    pub bytes: u64,
    /// Owned entity-ticks written.
    pub entity_ticks: u64,
    /// Entities the table did not know (left out).
    pub unknown: u64,
    last_flush: Instant,
}

impl PodRecorder {
    /// A recorder writing to a new file at `path`.
    pub fn create(path: &Path, table: EntityTable) -> Result<Self, RecordError> {
        let file = File::create(path).map_err(|e| {
            RecordError::Io(std::io::Error::new(
                e.kind(),
                format!("cannot create {}: {e}", path.display()),
            ))
        })?;
        Self::new(BufWriter::with_capacity(1 << 20, file), table)
    }
}

impl<W: Write> PodRecorder<W> {
    /// A recorder writing the header and then chunks to `out`.
    pub fn new(mut out: W, table: EntityTable) -> Result<Self, RecordError> {
        let mut header = Vec::new();
        write_header(&mut header, &table.header)?;
        out.write_all(&header)?;
        Ok(Self {
            out,
            encoder: ChunkEncoder::new(&table.header),
            table,
            chunk: StreamTick::default(),
            bytes: header.len() as u64,
            entity_ticks: 0,
            unknown: 0,
            last_flush: Instant::now(),
        })
    }

    fn stream_of(&self, cluster: ClusterId) -> Option<u16> {
        self.table.streams.get(&cluster).copied()
    }

    /// Writes `pod`'s tick that just ended, which took `tick_ns`.
    pub fn observe(&mut self, pod: &Pod, tick_ns: u64) -> Result<(), RecordError> {
        let me = pod.cluster().id();
        let Some(stream) = self.stream_of(me) else {
            return Err(RecordError::Header(format!(
                "pod {} is not a stream of this recording",
                pod.name()
            )));
        };
        let sim = pod.cluster().sim();
        let mut chunk = std::mem::take(&mut self.chunk);
        chunk.stream = stream;
        chunk.tick = sim.tick();
        chunk.tick_us = (tick_ns / 1000).min(u64::from(u32::MAX)) as u32;
        chunk.owned.clear();
        chunk.proxies.clear();
        chunk.ops.clear();
        chunk.contacts.clear();
        chunk.handoffs.clear();
        for (id, info, position, rotation) in sim.poses() {
            if info.owner == ClusterId::SCENERY {
                continue;
            }
            let Some(&entity) = self.table.entities.get(&id) else {
                self.unknown += 1;
                continue;
            };
            if info.owner == me {
                chunk.owned.push(OwnedPose {
                    entity,
                    mm: position.map(millimetres),
                    heading: if self.table.turns[entity as usize] {
                        heading(rotation)
                    } else {
                        0
                    },
                });
            } else {
                chunk.proxies.push(entity);
            }
        }
        chunk.owned.sort_unstable_by_key(|p| p.entity);
        chunk.proxies.sort_unstable();
        for op in pod.last_events().iter().filter_map(|e| match &e.event {
            ClusterEvent::OpApplied { timing, .. } => Some(timing),
            _ => None,
        }) {
            let Some(&target) = self.table.entities.get(&op.target) else {
                self.unknown += 1;
                continue;
            };
            chunk.ops.push(RecordedOp {
                from: self.stream_of(op.from),
                target,
                ticks_late: op.applied_tick.saturating_sub(op.issued_tick),
            });
        }
        for contact in sim.contacts() {
            let Some(reporter) = contact.reported_by else {
                continue;
            };
            let (Some(&a), Some(&b)) = (
                self.table.entities.get(&contact.a),
                self.table.entities.get(&contact.b),
            ) else {
                continue;
            };
            chunk.contacts.push(RecordedContact {
                a,
                b,
                started: contact.started,
                reporter: self.stream_of(reporter),
            });
        }
        for (entity, taken) in pod.last_events().iter().filter_map(|e| match e.event {
            ClusterEvent::HandoffTaken { entity, .. } => Some((entity, true)),
            ClusterEvent::HandoffGiven { entity, .. } => Some((entity, false)),
            _ => None,
        }) {
            match self.table.entities.get(&entity) {
                Some(&entity) => chunk.handoffs.push(RecordedHandoff { entity, taken }),
                None => self.unknown += 1,
            }
        }
        self.entity_ticks += chunk.owned.len() as u64;
        let chunk = Chunk::Tick(chunk);
        self.bytes += self.encoder.write(&mut self.out, &chunk)? as u64;
        if let Chunk::Tick(t) = chunk {
            self.chunk = t;
        }
        if self.last_flush.elapsed() >= FLUSH_EVERY {
            self.out.flush()?;
            self.last_flush = Instant::now();
        }
        Ok(())
    }

    /// Flushes and returns the writer.
    pub fn finish(mut self) -> Result<W, RecordError> {
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::millimetres;

    #[test]
    fn millimetres_round_to_nearest() {
        assert_eq!(millimetres(1.2344), 1234);
        assert_eq!(millimetres(1.2346), 1235);
        assert_eq!(millimetres(-1.2346), -1235);
        assert_eq!(millimetres(-0.0004), 0);
        assert_eq!(millimetres(f32::NAN), 0);
        assert_eq!(millimetres(1e12), i32::MAX);
    }
}
