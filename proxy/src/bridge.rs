//! A host's bridge: shared memory among the pods of one host, Redis between hosts.
//!
//! Every pod speaks `shm` to the pods of its own host. One bridge per host passes on exactly the
//! channels that cross the host boundary, in both directions, and nothing else:
//!
//! - **out** (this host's shared memory → Redis): `replication:L` of each cluster `L` here with a
//!   neighbour on another host, and `physics_events:R` of each cluster `R` elsewhere that a
//!   cluster here neighbours (the ops and contacts this host's pods send it);
//! - **in** (Redis → this host's shared memory): `replication:R` of those clusters elsewhere, and
//!   `physics_events:L` of the clusters here with a neighbour elsewhere.
//!
//! The two sets never share a channel, so nothing a bridge brings in goes out again, and each
//! message crosses Redis once per host that needs it: a frame two pods of another host read is
//! delivered to that host's bridge once and fanned out there on shared memory. Messages keep
//! their envelope ([`seam_transport::Transport::forward`]): a receiver tells publishers apart and
//! counts lost messages as if the frame had come straight from its publisher. A bridge that
//! stops silences its host's clusters to the others, which take them for dead and adopt what
//! they owned, exactly as for dead pods.
//!
//! Each direction runs on its own thread with its own transports and sleeps on its own receive
//! (iceoryx2's wake-up on one, the Redis socket on the other), so a message waits for no poll.
//! What has arrived by the time a direction wakes is passed on as one batch
//! ([`seam_transport::Transport::forward_all`]: one pipelined round trip on Redis), so the rate
//! a bridge sustains does not fall with the distance to the server.

use std::collections::BTreeSet;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use seam_sim::wire::ClusterId;
use seam_transport::{Transport, redact_url};

use crate::WorldCluster;
use crate::channels::{physics_events, replication};
use crate::error::ClusterError;

/// The channels one host's bridge passes on (see the module docs).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct BridgeRoutes {
    /// Subscribed on this host's shared memory and published to Redis.
    pub out: Vec<String>,
    /// Subscribed on Redis and published to this host's shared memory.
    pub into: Vec<String>,
}

impl BridgeRoutes {
    /// The routes of the host holding the clusters for which `here` is true, in a world whose
    /// clusters and neighbours `world` lists.
    pub fn for_host(world: &[WorldCluster], here: impl Fn(ClusterId) -> bool) -> Self {
        let mut out = BTreeSet::new();
        let mut into = BTreeSet::new();
        for cluster in world.iter().filter(|c| here(c.id)) {
            for &neighbour in cluster.neighbours.iter().filter(|&&n| !here(n)) {
                out.insert(replication(cluster.id));
                into.insert(physics_events(cluster.id));
                into.insert(replication(neighbour));
                out.insert(physics_events(neighbour));
            }
        }
        Self {
            out: out.into_iter().collect(),
            into: into.into_iter().collect(),
        }
    }

    /// Whether the host has nothing to pass on (no cluster of it neighbours another host's).
    pub fn is_empty(&self) -> bool {
        self.out.is_empty() && self.into.is_empty()
    }
}

/// What one direction of a bridge has done so far.
#[derive(Debug, Default)]
pub struct DirectionCounters {
    /// Messages passed on.
    pub messages: AtomicU64,
    /// Their payload bytes.
    pub bytes: AtomicU64,
    /// Messages the far side refused (too large, a port it could not open), dropped.
    pub refused: AtomicU64,
}

/// A snapshot of [`DirectionCounters`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct DirectionStats {
    /// Messages passed on.
    pub messages: u64,
    /// Their payload bytes.
    pub bytes: u64,
    /// Messages the far side refused, dropped.
    pub refused: u64,
}

impl DirectionCounters {
    /// The counters now.
    pub fn snapshot(&self) -> DirectionStats {
        DirectionStats {
            messages: self.messages.load(Ordering::Relaxed),
            bytes: self.bytes.load(Ordering::Relaxed),
            refused: self.refused.load(Ordering::Relaxed),
        }
    }
}

/// A running bridge: two threads, one per direction.
pub struct Bridge {
    /// Shared memory → Redis.
    pub out: Arc<DirectionCounters>,
    /// Redis → shared memory.
    pub into: Arc<DirectionCounters>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<Result<(), ClusterError>>>,
}

/// How long a bridge thread sleeps on its receive before looking at the stop flag.
const STOP_CHECK: Duration = Duration::from_millis(50);

impl Bridge {
    /// Starts passing on `routes` between the host's shared memory (`local`, e.g.
    /// `shm?prefix=host_a_`) and the deployment's Redis server (`remote`). Both transports of
    /// both directions are open and subscribed when this returns, so messages published from
    /// then on are passed on.
    pub fn start(local: &str, remote: &str, routes: &BridgeRoutes) -> Result<Self, ClusterError> {
        let stop = Arc::new(AtomicBool::new(false));
        let out = Arc::new(DirectionCounters::default());
        let into = Arc::new(DirectionCounters::default());
        let mut threads = Vec::new();
        let mut ready = Vec::new();
        for (name, from, to, channels, counters) in [
            ("out", local, remote, &routes.out, &out),
            ("in", remote, local, &routes.into, &into),
        ] {
            let (from, to) = (from.to_owned(), to.to_owned());
            let channels = channels.clone();
            let (counters, stop) = (Arc::clone(counters), Arc::clone(&stop));
            let (opened, opened_rx) = std::sync::mpsc::channel();
            ready.push(opened_rx);
            let thread = std::thread::Builder::new()
                .name(format!("bridge-{name}"))
                .spawn(move || pass_on(&from, &to, &channels, &counters, &stop, opened))
                .map_err(|_| ClusterError::BridgeThread("cannot start a bridge thread"))?;
            threads.push(thread);
        }
        let mut bridge = Self {
            out,
            into,
            stop,
            threads,
        };
        for opened in ready {
            if opened.recv().is_err() {
                // The thread ended before opening: its error says why.
                return Err(bridge.stop().err().unwrap_or(ClusterError::BridgeThread(
                    "a bridge thread ended before opening its transports",
                )));
            }
        }
        Ok(bridge)
    }

    /// Stops both directions and waits for them; the first error either met, if any.
    pub fn stop(&mut self) -> Result<(), ClusterError> {
        self.stop.store(true, Ordering::Relaxed);
        let mut first = Ok(());
        for thread in self.threads.drain(..) {
            let result = thread
                .join()
                .unwrap_or(Err(ClusterError::BridgeThread("a bridge thread panicked")));
            if first.is_ok() {
                first = result;
            }
        }
        first
    }

    /// Whether a direction has ended (on an error; see [`Bridge::stop`]).
    pub fn has_failed(&self) -> bool {
        self.threads.iter().any(JoinHandle::is_finished)
    }
}

impl Drop for Bridge {
    fn drop(&mut self) {
        let _ = self.stop();
    }
}

/// One direction: receives `channels` on `from` and forwards each message to `to`.
fn pass_on(
    from: &str,
    to: &str,
    channels: &[String],
    counters: &DirectionCounters,
    stop: &AtomicBool,
    opened: std::sync::mpsc::Sender<()>,
) -> Result<(), ClusterError> {
    let at = |url: &str| {
        let url = redact_url(url).to_string();
        move |e: ClusterError| ClusterError::Bridge {
            url,
            source: Box::new(e),
        }
    };
    let open = |url: &str| seam_transport::open(url).map_err(|e| at(url)(e.into()));
    let mut source: Box<dyn Transport> = open(from)?;
    let mut sink: Box<dyn Transport> = open(to)?;
    for channel in channels {
        source.subscribe(channel).map_err(|e| at(from)(e.into()))?;
        // Publishing ports made now: the first message costs no more than the next.
        let _ = sink.advertise(channel, 0);
    }
    let _ = opened.send(());
    let failed = |e: seam_transport::ReceiveError| at(from)(e.into());
    let mut batch = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        // Sleep until something comes, then take whatever else is already here: the batch goes
        // out together (one round trip on Redis), so a far server does not hold the host back.
        let Some(first) = source.receive_timeout(STOP_CHECK).map_err(failed)? else {
            continue;
        };
        batch.push(first.to_owned());
        let mut bytes = batch[0].payload.len();
        while batch.len() < MAX_BATCH && bytes < MAX_BATCH_BYTES {
            let Some(next) = source.try_receive().map_err(failed)? else {
                break;
            };
            bytes += next.payload.len();
            batch.push(next.to_owned());
        }
        match sink.forward_all(&batch) {
            Ok(_) => {
                counters
                    .messages
                    .fetch_add(batch.len() as u64, Ordering::Relaxed);
                counters.bytes.fetch_add(bytes as u64, Ordering::Relaxed);
            }
            Err(e) => {
                counters
                    .refused
                    .fetch_add(batch.len() as u64, Ordering::Relaxed);
                tracing::debug!(messages = batch.len(), error = %e, "bridge: not passed on");
            }
        }
        batch.clear();
    }
    Ok(())
}

/// Most messages a bridge sends as one batch.
const MAX_BATCH: usize = 256;
/// Most payload bytes in one batch.
const MAX_BATCH_BYTES: usize = 8 << 20;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Region;
    use crate::world::world_map;

    fn region(x0: f32, z0: f32) -> Region {
        Region {
            min: [x0, -10.0, z0],
            max: [x0 + 10.0, 10.0, z0 + 10.0],
        }
    }

    #[test]
    fn routes_cross_the_host_boundary_only() {
        // A 2 × 2 grid; host "south" holds sw and se, host "north" nw and ne; all touch.
        let ids: Vec<ClusterId> = ["sw", "se", "nw", "ne"]
            .iter()
            .map(|name| ClusterId::named("bridge-test", name))
            .collect();
        let world = world_map(&[
            (ids[0], region(-10.0, -10.0), 1.0),
            (ids[1], region(0.0, -10.0), 1.0),
            (ids[2], region(-10.0, 0.0), 1.0),
            (ids[3], region(0.0, 0.0), 1.0),
        ]);
        let is_south = |c: ClusterId| c == ids[0] || c == ids[1];
        let south = BridgeRoutes::for_host(&world, is_south);
        let north = BridgeRoutes::for_host(&world, |c| !is_south(c));
        let mut expected_out: Vec<String> = ids[..2].iter().map(|&c| replication(c)).collect();
        expected_out.extend(ids[2..].iter().map(|&c| physics_events(c)));
        expected_out.sort();
        assert_eq!(south.out, expected_out);
        // What one host sends is what the other takes in, and nothing goes both ways.
        assert_eq!(south.out, north.into);
        assert_eq!(north.out, south.into);
        assert!(south.out.iter().all(|c| !south.into.contains(c)));
        // One host holding everything passes nothing on.
        assert!(BridgeRoutes::for_host(&world, |_| true).is_empty());
    }
}
