//! One recording out of the pods' own (each pod of a run writes its stream to a part file).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::{
    Chunk, ChunkDecoder, ChunkEncoder, Fault, Header, RecordError, read_header, write_header,
};

/// What a merge wrote.
#[derive(Debug, Clone, Default)]
pub struct MergeSummary {
    /// Part files read.
    pub parts: usize,
    /// Chunks written.
    pub chunks: u64,
    /// Owned entity-ticks written.
    pub entity_ticks: u64,
    /// Distinct ticks written.
    pub ticks: u64,
    /// Bytes written.
    pub bytes: u64,
    /// Parts that ended inside a chunk (a pod killed mid-write): their last chunk is lost.
    pub cut_short: usize,
}

/// Every `*.part` file in `dir`, in name order.
pub fn part_files(dir: &Path) -> Result<Vec<PathBuf>, RecordError> {
    let mut parts: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "part"))
        .collect();
    parts.sort();
    Ok(parts)
}

/// Merges the part files `parts` (recordings of one run, one stream each, or several
/// incarnations of a stream) and `faults` into one recording at `out`, in tick order, with
/// `source` as the header's source. Every part must have the same header but for its source.
pub fn merge_parts(
    parts: &[PathBuf],
    faults: &[Fault],
    source: &str,
    out: &Path,
) -> Result<MergeSummary, RecordError> {
    let mut header: Option<Header> = None;
    let mut inputs = Vec::new();
    for path in parts {
        let bytes = std::fs::read(path)?;
        let mut rest: &[u8] = &bytes;
        let part_header = read_header(&mut rest)?;
        let offset = bytes.len() - rest.len();
        match &header {
            None => header = Some(part_header.clone()),
            Some(h) if same_run(h, &part_header) => {}
            Some(_) => {
                return Err(RecordError::Header(format!(
                    "{} is a recording of another run",
                    path.display()
                )));
            }
        }
        let decoder = ChunkDecoder::new(&part_header);
        inputs.push((bytes, offset, decoder, None::<Chunk>));
    }
    let Some(mut header) = header else {
        return Err(RecordError::Header("no part files to merge".into()));
    };
    header.source = source.into();
    let file = File::create(out).map_err(|e| {
        RecordError::Io(std::io::Error::new(
            e.kind(),
            format!("cannot create {}: {e}", out.display()),
        ))
    })?;
    let mut writer = BufWriter::with_capacity(1 << 20, file);
    let mut head = Vec::new();
    write_header(&mut head, &header)?;
    writer.write_all(&head)?;
    let mut summary = MergeSummary {
        parts: parts.len(),
        bytes: head.len() as u64,
        ..MergeSummary::default()
    };
    let mut encoder = ChunkEncoder::new(&header);
    let mut faults: Vec<&Fault> = faults.iter().collect();
    faults.sort_by_key(|f| f.tick);
    let mut faults = faults.into_iter().peekable();
    let mut last_tick = None;
    loop {
        // Refill each part's next chunk, then write the earliest.
        for (bytes, offset, decoder, next) in &mut inputs {
            if next.is_none() {
                let mut rest = &bytes[*offset..];
                *next = decoder.next_chunk(&mut rest)?;
                *offset = bytes.len() - rest.len();
                if next.is_none() && decoder.cut_short {
                    summary.cut_short += 1;
                    *offset = bytes.len();
                }
            }
        }
        let earliest = inputs
            .iter()
            .filter_map(|(_, _, _, next)| next.as_ref().map(Chunk::tick))
            .min();
        let fault = faults.peek().map(|f| f.tick);
        let chunk = match (earliest, fault) {
            (None, None) => break,
            (tick, Some(f)) if tick.is_none_or(|t| f <= t) => match faults.next() {
                Some(f) => Chunk::Fault(f.clone()),
                None => break,
            },
            (tick, _) => {
                let next = inputs
                    .iter_mut()
                    .find(|(_, _, _, next)| next.as_ref().map(Chunk::tick) == tick)
                    .and_then(|(_, _, _, next)| next.take());
                match next {
                    Some(chunk) => chunk,
                    None => break,
                }
            }
        };
        summary.bytes += encoder.write(&mut writer, &chunk)? as u64;
        summary.chunks += 1;
        if let Chunk::Tick(t) = &chunk {
            summary.entity_ticks += t.owned.len() as u64;
            if last_tick != Some(t.tick) {
                summary.ticks += 1;
                last_tick = Some(t.tick);
            }
        }
    }
    writer.flush()?;
    Ok(summary)
}

/// A folder for a run's part files: beside the recording it will be merged into (`FILE.parts`),
/// or a temporary one; removed with what is in it when dropped.
pub struct PartsDir {
    /// The folder.
    pub dir: PathBuf,
}

impl PartsDir {
    /// Makes the folder (emptied of part files an earlier run left).
    pub fn beside(out: Option<&Path>) -> Result<Self, RecordError> {
        let dir = match out {
            Some(out) => {
                let mut name = out.as_os_str().to_owned();
                name.push(".parts");
                PathBuf::from(name)
            }
            None => std::env::temp_dir().join(format!(
                "seam-live-{}-{}",
                std::process::id(),
                seam_proxy::monotonic_ns()
            )),
        };
        std::fs::create_dir_all(&dir).map_err(|e| {
            RecordError::Io(std::io::Error::new(
                e.kind(),
                format!("cannot make {}: {e}", dir.display()),
            ))
        })?;
        for stale in part_files(&dir)? {
            std::fs::remove_file(stale)?;
        }
        Ok(Self { dir })
    }

    /// Merges the part files in the folder into `out` (see [`merge_parts`]).
    pub fn merge_into(
        &self,
        out: &Path,
        faults: &[Fault],
        source: &str,
    ) -> Result<MergeSummary, RecordError> {
        merge_parts(&part_files(&self.dir)?, faults, source, out)
    }
}

impl Drop for PartsDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

impl MergeSummary {
    /// One line for the console: what was written where.
    pub fn line(&self, out: &Path) -> String {
        format!(
            "recorded {} ticks, {} entity-ticks owned: {:.1} MB ({:.1} bytes per entity-tick) -> {}{}",
            self.ticks,
            self.entity_ticks,
            self.bytes as f64 / 1e6,
            self.bytes as f64 / self.entity_ticks.max(1) as f64,
            out.display(),
            if self.cut_short > 0 {
                format!(" ({} part files ended mid-chunk)", self.cut_short)
            } else {
                String::new()
            }
        )
    }
}

fn same_run(a: &Header, b: &Header) -> bool {
    a.scene == b.scene
        && a.run_id == b.run_id
        && a.streams == b.streams
        && a.entities == b.entities
        && a.groups == b.groups
}
