//! Bad frames on every channel of a run: garbage that must be refused, and forged ownership
//! claims that must be ignored.
//!
//! The injector is one more client of the run's transport. It listens to every replication
//! channel (so it has each cluster's latest real frame to corrupt or forge from) and, on each
//! [`Injector::burst`], publishes per cluster `X`:
//!
//! - on `replication:X`: random bytes, a real frame of `X` cut in half, a real frame of `X`
//!   with another format version, a real frame of another cluster (wrong sender), and a forged
//!   claim: the frame of `X` the previous burst saw (about a quarter of a second old), same
//!   tick, with a state of another cluster's entity marked as `X`'s;
//! - on `physics_events:X`: random bytes.
//!
//! Every delivery of the first kind must show up in a receiver's refusal counters (undecodable,
//! other version, wrong sender); every delivery of a forged claim as a replay: `X` has
//! published newer frames since, and the receiver has taken some, even if it lost that very
//! frame (to a full buffer, or to a Redis outage: a forged copy of the latest frame was then
//! taken as new, 2 of 17 408 in a ten-minute run with 40 Redis restarts).

use seam_proxy::{physics_events, replication};
use seam_sim::wire::{self, ClusterId, IdMap, ReplicationFrame, WIRE_VERSION};
use seam_transport::Transport;
use serde::Serialize;

use crate::error::{BenchError, BenchResult};

/// What the injector sent, and how many subscribers it reached.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct InjectCounts {
    /// Garbage frames published (random, truncated, other version, wrong sender).
    pub garbage_frames: u64,
    /// Times a garbage frame reached a pod's subscriber.
    pub garbage_deliveries: u64,
    /// Forged ownership claims published.
    pub forged_frames: u64,
    /// Times one reached a pod.
    pub forged_deliveries: u64,
}

/// Publishes bad frames into a running scene's channels.
pub struct Injector {
    transport: Box<dyn Transport>,
    clusters: Vec<ClusterId>,
    latest: IdMap<ClusterId, ReplicationFrame>,
    /// `latest` as the previous burst found it: what forged claims copy.
    earlier: IdMap<ClusterId, ReplicationFrame>,
    rng: u64,
    counts: InjectCounts,
}

impl Injector {
    /// Opens `url` and listens to the replication channels of `clusters`.
    pub fn new(url: &str, clusters: Vec<ClusterId>, seed: u64) -> BenchResult<Self> {
        let mut transport = seam_transport::open(url)?;
        for &cluster in &clusters {
            transport.subscribe(&replication(cluster))?;
        }
        Ok(Self {
            transport,
            clusters,
            latest: IdMap::default(),
            earlier: IdMap::default(),
            rng: seed.max(1),
            counts: InjectCounts::default(),
        })
    }

    /// What was sent so far.
    pub fn counts(&self) -> InjectCounts {
        self.counts
    }

    /// Takes the frames that arrived, keeping each cluster's latest.
    pub fn observe(&mut self) -> BenchResult<()> {
        while let Some(message) = self.transport.try_receive()? {
            if let Ok(frame) = ReplicationFrame::decode(message.payload)
                && self
                    .latest
                    .get(&frame.from)
                    .is_none_or(|f| f.tick < frame.tick)
            {
                self.latest.insert(frame.from, frame);
            }
        }
        Ok(())
    }

    fn next(&mut self) -> u64 {
        // xorshift64*
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn random_bytes(&mut self) -> Vec<u8> {
        let len = (self.next() % 300) as usize;
        (0..len).map(|_| self.next() as u8).collect()
    }

    /// Publishes `payload` on `channel`; returns how many pods it reached (`listening` is 1 on
    /// the replication channels, which the injector itself subscribes to).
    fn send(&mut self, channel: &str, payload: &[u8], listening: usize) -> BenchResult<u64> {
        let reached = self.transport.publish(channel, payload)?;
        Ok(reached.saturating_sub(listening) as u64)
    }

    /// One burst on every channel (see the module docs). Call it only while every pod runs:
    /// a frame delivered to a pod that dies is not counted anywhere, and a forged frame of a
    /// dead cluster would make it look alive.
    pub fn burst(&mut self) -> BenchResult<()> {
        self.earlier.clone_from(&self.latest);
        self.observe()?;
        for index in 0..self.clusters.len() {
            let cluster = self.clusters[index];
            let other = self.clusters[(index + 1) % self.clusters.len()];
            let channel = replication(cluster);
            let mut garbage = vec![self.random_bytes(), self.random_bytes()];
            if let Some(real) = self.latest.get(&cluster) {
                let bytes = encode(real)?;
                garbage.push(bytes[..bytes.len() / 2].to_vec());
                let mut other_version = bytes;
                other_version[0] = WIRE_VERSION.wrapping_add(1);
                garbage.push(other_version);
            }
            if other != cluster
                && let Some(theirs) = self.latest.get(&other)
            {
                garbage.push(encode(theirs)?);
            }
            for payload in garbage {
                self.counts.garbage_frames += 1;
                self.counts.garbage_deliveries += self.send(&channel, &payload, 1)?;
            }
            let events = physics_events(cluster);
            for _ in 0..2 {
                let payload = self.random_bytes();
                self.counts.garbage_frames += 1;
                self.counts.garbage_deliveries += self.send(&events, &payload, 0)?;
            }
            let stolen = self
                .latest
                .get(&other)
                .and_then(|theirs| theirs.states.iter().find(|s| s.cluster_id == other))
                .copied();
            if let (Some(real), Some(stolen), true) =
                (self.earlier.get(&cluster), stolen, other != cluster)
            {
                let mut forged = real.clone();
                forged.states.push(wire::EntityState {
                    cluster_id: cluster,
                    ..stolen
                });
                let payload = encode(&forged)?;
                self.counts.forged_frames += 1;
                self.counts.forged_deliveries += self.send(&channel, &payload, 1)?;
            }
        }
        Ok(())
    }
}

/// A frame as pods publish it by default.
fn encode(frame: &ReplicationFrame) -> BenchResult<Vec<u8>> {
    frame
        .encode(wire::StateEncoding::Exact)
        .map_err(BenchError::from)
}
