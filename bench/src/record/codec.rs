//! Chunk bytes (see the format in the module above): varints, and positions as changes since
//! the stream's previous chunk.

use std::io::Write;

use super::{
    CHUNK_FAULT, CHUNK_TICK, Chunk, Fault, Header, MAX_CHUNK, OwnedPose, RecordError,
    RecordedContact, RecordedHandoff, RecordedOp, StreamTick,
};

fn put(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn put_signed(out: &mut Vec<u8>, v: i64) {
    put(out, ((v << 1) ^ (v >> 63)) as u64);
}

fn put_stream(out: &mut Vec<u8>, stream: Option<u16>) {
    put(out, stream.map_or(0, |s| u64::from(s) + 1));
}

/// Per entity: the stream chunk it was last owned in, and where (mm).
type LastSeen = Vec<(u32, [i32; 3])>;

/// Where each stream's entities were in its previous chunk.
struct Previous {
    /// Per stream: the number of chunks it has had, and its entities' [`LastSeen`].
    streams: Vec<(u32, LastSeen)>,
    entities: usize,
}

impl Previous {
    fn new(header: &Header) -> Self {
        Self {
            streams: Vec::new(),
            entities: header.entities as usize,
        }
    }

    fn stream(&mut self, stream: u16) -> &mut (u32, LastSeen) {
        let s = stream as usize;
        if self.streams.len() <= s {
            self.streams.resize_with(s + 1, Default::default);
        }
        let entry = &mut self.streams[s];
        if entry.1.is_empty() {
            entry.1 = vec![(0, [0; 3]); self.entities];
        }
        entry
    }
}

/// Writes chunks, keeping what delta positions need.
pub struct ChunkEncoder {
    previous: Previous,
    streams: usize,
    body: Vec<u8>,
}

impl ChunkEncoder {
    /// An encoder for a recording with `header`.
    pub fn new(header: &Header) -> Self {
        Self {
            previous: Previous::new(header),
            streams: header.streams.len(),
            body: Vec::new(),
        }
    }

    /// Writes `chunk`; returns the bytes written. Owned entities and proxies must be in
    /// ascending index order, below the header's entity count, in a stream it names.
    pub fn write(&mut self, out: &mut impl Write, chunk: &Chunk) -> Result<usize, RecordError> {
        self.body.clear();
        let kind = match chunk {
            Chunk::Tick(t) => {
                self.tick_body(t)?;
                CHUNK_TICK
            }
            Chunk::Fault(f) => {
                put(&mut self.body, f.tick);
                put_stream(&mut self.body, f.stream);
                put(&mut self.body, f.what.len() as u64);
                self.body.extend_from_slice(f.what.as_bytes());
                CHUNK_FAULT
            }
        };
        out.write_all(&[kind])?;
        out.write_all(&(self.body.len() as u32).to_le_bytes())?;
        out.write_all(&self.body)?;
        Ok(5 + self.body.len())
    }

    fn tick_body(&mut self, t: &StreamTick) -> Result<(), RecordError> {
        let bad = |why: String| RecordError::Chunk {
            tick: Some(t.tick),
            why,
        };
        if t.stream as usize >= self.streams {
            return Err(bad(format!("stream {} of {}", t.stream, self.streams)));
        }
        let entities = self.previous.entities as u32;
        let out = &mut self.body;
        put(out, u64::from(t.stream));
        put(out, t.tick);
        put(out, u64::from(t.tick_us));
        let (number, last) = self.previous.stream(t.stream);
        let chunk = *number + 2;
        *number += 1;
        put(out, t.owned.len() as u64);
        let mut before = 0u32;
        for (i, pose) in t.owned.iter().enumerate() {
            if pose.entity >= entities || (i > 0 && pose.entity <= before) {
                return Err(bad(format!("owned entity {} out of order", pose.entity)));
            }
            put(out, u64::from(pose.entity - if i > 0 { before } else { 0 }));
            before = pose.entity;
            let (seen, at) = &mut last[pose.entity as usize];
            let base = if *seen + 1 == chunk { *at } else { [0; 3] };
            for (now, before) in pose.mm.iter().zip(base) {
                put_signed(out, i64::from(*now) - i64::from(before));
            }
            out.push(pose.heading);
            *seen = chunk;
            *at = pose.mm;
        }
        put(out, t.proxies.len() as u64);
        for (i, &entity) in t.proxies.iter().enumerate() {
            if entity >= entities || (i > 0 && entity <= t.proxies[i - 1]) {
                return Err(bad(format!("proxy {entity} out of order")));
            }
            put(
                out,
                u64::from(entity - if i > 0 { t.proxies[i - 1] } else { 0 }),
            );
        }
        put(out, t.ops.len() as u64);
        for op in &t.ops {
            put_stream(out, op.from);
            put(out, u64::from(op.target));
            put(out, op.ticks_late);
        }
        put(out, t.contacts.len() as u64);
        for c in &t.contacts {
            put(out, u64::from(c.a));
            put(out, u64::from(c.b));
            out.push(u8::from(c.started));
            put_stream(out, c.reporter);
        }
        put(out, t.handoffs.len() as u64);
        for h in &t.handoffs {
            if h.entity >= entities {
                return Err(bad(format!("hand-off of entity {}", h.entity)));
            }
            put(out, u64::from(h.entity));
            out.push(u8::from(h.taken));
        }
        Ok(())
    }
}

/// Reads chunks, keeping what delta positions need.
pub struct ChunkDecoder {
    previous: Previous,
    streams: usize,
    /// Chunks of unknown kind skipped.
    pub skipped: u64,
    /// Whether the last call stopped at a chunk cut short.
    pub cut_short: bool,
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    tick: Option<u64>,
}

impl Reader<'_> {
    fn fail(&self, why: impl Into<String>) -> RecordError {
        RecordError::Chunk {
            tick: self.tick,
            why: why.into(),
        }
    }

    fn varint(&mut self) -> Result<u64, RecordError> {
        let mut v = 0u64;
        for shift in (0..70).step_by(7) {
            let Some(&byte) = self.bytes.get(self.at) else {
                return Err(self.fail("ends inside a number"));
            };
            self.at += 1;
            if shift == 63 && byte > 1 {
                return Err(self.fail("number too large"));
            }
            v |= u64::from(byte & 0x7f) << shift;
            if byte < 0x80 {
                return Ok(v);
            }
        }
        Err(self.fail("number too long"))
    }

    fn small(&mut self, limit: u64, what: &str) -> Result<u32, RecordError> {
        let v = self.varint()?;
        if v >= limit {
            return Err(self.fail(format!("{what} {v} (at most {})", limit.saturating_sub(1))));
        }
        Ok(v as u32)
    }

    fn signed(&mut self) -> Result<i64, RecordError> {
        let u = self.varint()?;
        Ok((u >> 1) as i64 ^ -((u & 1) as i64))
    }

    fn byte(&mut self) -> Result<u8, RecordError> {
        let byte = *self
            .bytes
            .get(self.at)
            .ok_or_else(|| self.fail("ends early"))?;
        self.at += 1;
        Ok(byte)
    }

    fn stream(&mut self, streams: usize) -> Result<Option<u16>, RecordError> {
        let v = self.small(streams as u64 + 1, "stream")?;
        Ok(v.checked_sub(1).map(|s| s as u16))
    }

    /// A count of items at least `min_bytes` long each, checked against what is left.
    fn count(&mut self, min_bytes: usize) -> Result<usize, RecordError> {
        let n = self.varint()?;
        let left = (self.bytes.len() - self.at) as u64;
        if n.saturating_mul(min_bytes as u64) > left {
            return Err(self.fail(format!("{n} items in {left} bytes")));
        }
        Ok(n as usize)
    }
}

impl ChunkDecoder {
    /// A decoder for a recording with `header`.
    pub fn new(header: &Header) -> Self {
        Self {
            previous: Previous::new(header),
            streams: header.streams.len(),
            skipped: 0,
            cut_short: false,
        }
    }

    /// The next chunk of `input`, which moves past it. `None` at the end, or at a chunk cut
    /// short (then `cut_short` is set and `input` stays at its start, so a reader of a file
    /// still being written can try again with more bytes).
    pub fn next_chunk(&mut self, input: &mut &[u8]) -> Result<Option<Chunk>, RecordError> {
        loop {
            self.cut_short = false;
            if input.is_empty() {
                return Ok(None);
            }
            if input.len() < 5 {
                self.cut_short = true;
                return Ok(None);
            }
            let kind = input[0];
            let len = u32::from_le_bytes([input[1], input[2], input[3], input[4]]) as usize;
            if len > MAX_CHUNK {
                return Err(RecordError::Chunk {
                    tick: None,
                    why: format!("{len} bytes long"),
                });
            }
            if input.len() < 5 + len {
                self.cut_short = true;
                return Ok(None);
            }
            let body = &input[5..5 + len];
            *input = &input[5 + len..];
            let mut reader = Reader {
                bytes: body,
                at: 0,
                tick: None,
            };
            let chunk = match kind {
                CHUNK_TICK => Chunk::Tick(self.tick(&mut reader)?),
                CHUNK_FAULT => {
                    let tick = reader.varint()?;
                    reader.tick = Some(tick);
                    let stream = reader.stream(self.streams)?;
                    let n = reader.count(1)?;
                    let what = String::from_utf8_lossy(&body[reader.at..reader.at + n]).into();
                    reader.at += n;
                    Chunk::Fault(Fault { tick, stream, what })
                }
                _ => {
                    self.skipped += 1;
                    continue;
                }
            };
            if reader.at != body.len() {
                return Err(reader.fail(format!("{} bytes left over", body.len() - reader.at)));
            }
            return Ok(Some(chunk));
        }
    }

    fn tick(&mut self, r: &mut Reader<'_>) -> Result<StreamTick, RecordError> {
        let stream = r.small(self.streams as u64, "stream")? as u16;
        let tick = r.varint()?;
        r.tick = Some(tick);
        let tick_us = r.varint()?.min(u64::from(u32::MAX)) as u32;
        let entities = self.previous.entities as u64;
        let (number, last) = self.previous.stream(stream);
        let chunk = *number + 2;
        *number += 1;
        let n = r.count(5)?;
        let mut owned = Vec::with_capacity(n);
        let mut entity = 0u64;
        for i in 0..n {
            let step = r.varint()?;
            if i > 0 && step == 0 {
                return Err(r.fail("owned entities out of order"));
            }
            entity = entity.saturating_add(step);
            if entity >= entities {
                return Err(r.fail(format!("entity {entity} of {entities}")));
            }
            let (seen, at) = &mut last[entity as usize];
            let base = if *seen + 1 == chunk { *at } else { [0; 3] };
            let mut mm = [0i32; 3];
            for axis in 0..3 {
                let v = i64::from(base[axis]).saturating_add(r.signed()?);
                mm[axis] = i32::try_from(v).map_err(|_| r.fail("position out of range"))?;
            }
            let heading = r.byte()?;
            *seen = chunk;
            *at = mm;
            owned.push(OwnedPose {
                entity: entity as u32,
                mm,
                heading,
            });
        }
        let n = r.count(1)?;
        let mut proxies = Vec::with_capacity(n);
        let mut entity = 0u64;
        for i in 0..n {
            let step = r.varint()?;
            if i > 0 && step == 0 {
                return Err(r.fail("proxies out of order"));
            }
            entity = entity.saturating_add(step);
            if entity >= entities {
                return Err(r.fail(format!("proxy {entity} of {entities}")));
            }
            proxies.push(entity as u32);
        }
        let n = r.count(3)?;
        let mut ops = Vec::with_capacity(n);
        for _ in 0..n {
            ops.push(RecordedOp {
                from: r.stream(self.streams)?,
                target: r.small(entities, "op target")?,
                ticks_late: r.varint()?,
            });
        }
        let n = r.count(4)?;
        let mut contacts = Vec::with_capacity(n);
        for _ in 0..n {
            contacts.push(RecordedContact {
                a: r.small(entities, "contact entity")?,
                b: r.small(entities, "contact entity")?,
                started: r.byte()? != 0,
                reporter: r.stream(self.streams)?,
            });
        }
        let n = r.count(2)?;
        let mut handoffs = Vec::with_capacity(n);
        for _ in 0..n {
            handoffs.push(RecordedHandoff {
                entity: r.small(entities, "hand-off entity")?,
                taken: r.byte()? != 0,
            });
        }
        Ok(StreamTick {
            stream,
            tick,
            tick_us,
            owned,
            proxies,
            ops,
            contacts,
            handoffs,
        })
    }
}
