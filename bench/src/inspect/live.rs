//! A recording read while the pods of a run still write it: their part files, tailed a few
//! times a second and merged as they grow.

use std::collections::BTreeMap;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use crate::record::{ChunkDecoder, ChunkEncoder, Header, read_header, write_header};

/// How often the part files are read.
const POLL: Duration = Duration::from_millis(250);

/// One part file, read up to `offset`.
#[derive(Default)]
struct Tail {
    offset: u64,
    /// Bytes read but not yet a whole chunk (or header).
    pending: Vec<u8>,
    decoder: Option<ChunkDecoder>,
}

#[derive(Default)]
struct Inner {
    tails: BTreeMap<PathBuf, Tail>,
    merged: Vec<u8>,
    encoder: Option<(Header, ChunkEncoder)>,
    done: bool,
    problem: Option<String>,
}

/// The merged recording of the part files in a folder, growing as they do.
#[derive(Clone)]
pub struct LiveRecording {
    inner: Arc<Mutex<Inner>>,
}

impl LiveRecording {
    /// Follows the `*.part` files in `dir` from a thread of its own until [`finish`].
    ///
    /// [`finish`]: LiveRecording::finish
    pub fn watch(dir: &Path) -> Self {
        let live = Self {
            inner: Arc::default(),
        };
        let (follower, dir) = (live.clone(), dir.to_owned());
        std::thread::spawn(move || {
            loop {
                follower.poll(&dir);
                if follower.lock().done {
                    break;
                }
                std::thread::sleep(POLL);
            }
        });
        live
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Reads what the part files in `dir` gained since the last poll.
    pub fn poll(&self, dir: &Path) {
        let parts = match crate::record::part_files(dir) {
            Ok(parts) => parts,
            Err(_) => return,
        };
        let mut inner = self.lock();
        for path in parts {
            if let Err(e) = inner.read_part(&path) {
                inner.problem = Some(format!("{}: {e}", path.display()));
            }
        }
    }

    /// The last poll is done: readers are told the recording is whole.
    pub fn finish(&self, dir: &Path) {
        self.poll(dir);
        self.lock().done = true;
    }

    /// The merged recording from byte `from` on, and whether it is finished.
    pub fn bytes_from(&self, from: usize) -> (Vec<u8>, bool) {
        let inner = self.lock();
        (
            inner.merged.get(from..).unwrap_or_default().to_vec(),
            inner.done,
        )
    }

    /// What went wrong reading a part file, if anything did.
    pub fn problem(&self) -> Option<String> {
        self.lock().problem.clone()
    }
}

impl Inner {
    fn read_part(&mut self, path: &Path) -> Result<(), crate::record::RecordError> {
        let tail = self.tails.entry(path.to_owned()).or_default();
        let mut file = std::fs::File::open(path)?;
        file.seek(SeekFrom::Start(tail.offset))?;
        let read = file.read_to_end(&mut tail.pending)?;
        tail.offset += read as u64;
        if tail.decoder.is_none() {
            let mut input: &[u8] = &tail.pending;
            let Ok(header) = read_header(&mut input) else {
                // Not all of the header is there yet.
                return Ok(());
            };
            let used = tail.pending.len() - input.len();
            tail.pending.drain(..used);
            tail.decoder = Some(ChunkDecoder::new(&header));
            if self.encoder.is_none() {
                let mut header = header;
                header.source = "seam run (live)".into();
                write_header(&mut self.merged, &header)?;
                let encoder = ChunkEncoder::new(&header);
                self.encoder = Some((header, encoder));
            }
        }
        let (Some(decoder), Some((_, encoder))) = (&mut tail.decoder, &mut self.encoder) else {
            return Ok(());
        };
        let mut input: &[u8] = &tail.pending;
        while let Some(chunk) = decoder.next_chunk(&mut input)? {
            encoder.write(&mut self.merged, &chunk)?;
        }
        let used = tail.pending.len() - input.len();
        tail.pending.drain(..used);
        Ok(())
    }
}
