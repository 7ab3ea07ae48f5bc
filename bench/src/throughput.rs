//! `seam throughput`: messages a second through one Redis server and through Redis Clusters
//! of one and three primaries, at fixed offered loads up to saturation, with each server's CPU.
//!
//! Each target is made here: a private `redis-server`, or a private cluster
//! (`tools/redis-cluster up --primaries N`). For each offered load, publisher threads (each
//! with its own transport, as pods have) publish payloads round robin over `channels`
//! channels named with hash tags (`load:{I}`, spread over the slots) at the load's pace, and
//! subscriber threads, each subscribed to every channel, count what arrives. Over the window
//! the servers' CPU (`INFO cpu`, user + system) is read before and after: for a cluster, each
//! primary's. A load is *saturated* when the subscribers got less than 95 % of it.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Barrier};
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::document::{Align::*, Document, Table, grouped};
use crate::error::{BenchError, BenchResult};
use crate::redis_cluster::RedisCluster;
use crate::redis_server::{RedisServer, server_cpu_s};

/// What carries the load.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// One `redis-server`.
    Server,
    /// A Redis Cluster of this many primaries (each with a replica).
    Cluster(u16),
}

impl Target {
    /// Reads `server` or `cluster:N` (N from 1 to 3).
    pub fn parse(text: &str) -> Option<Self> {
        match text {
            "server" => Some(Target::Server),
            _ => text
                .strip_prefix("cluster:")
                .and_then(|n| n.parse().ok())
                .filter(|n| (1..=3).contains(n))
                .map(Target::Cluster),
        }
    }

    fn name(self) -> String {
        match self {
            Target::Server => "one server".to_owned(),
            Target::Cluster(1) => "cluster, 1 primary".to_owned(),
            Target::Cluster(n) => format!("cluster, {n} primaries"),
        }
    }
}

/// What `seam throughput` measures.
#[derive(Debug, Clone)]
pub struct ThroughputPlan {
    /// The targets, in order.
    pub targets: Vec<Target>,
    /// Offered loads, messages a second from all publishers together.
    pub rates: Vec<u64>,
    /// How long each load is offered.
    pub window: Duration,
    /// Channels the load is spread over.
    pub channels: usize,
    /// Publisher threads.
    pub publishers: usize,
    /// Subscriber threads, each subscribed to every channel.
    pub subscribers: usize,
    /// Payload bytes.
    pub size: usize,
}

/// One target at one load.
#[derive(Debug, Clone, Serialize)]
pub struct ThroughputRow {
    /// `one server`, `cluster, N primaries`.
    pub target: String,
    /// Primaries (1 for one server).
    pub nodes: usize,
    /// Messages a second offered.
    pub offered_per_s: u64,
    /// Messages a second published (publishers can fall behind the pace).
    pub published_per_s: f64,
    /// Messages a second each subscriber received (mean over subscribers).
    pub delivered_per_s: f64,
    /// CPU of the busiest primary over the window, percent of one core.
    pub busiest_node_cpu_pct: f64,
    /// Mean CPU of the primaries, percent of one core.
    pub mean_node_cpu_pct: f64,
    /// Whether the subscribers got less than 95 % of the offered load.
    pub saturated: bool,
}

/// A running target: its URL and the URLs of the servers whose CPU counts.
struct Running {
    url: String,
    cpu_urls: Vec<String>,
    _server: Option<RedisServer>,
    _cluster: Option<RedisCluster>,
}

fn start(target: Target) -> BenchResult<Running> {
    Ok(match target {
        Target::Server => {
            let server = RedisServer::start()?;
            Running {
                url: server.url(),
                cpu_urls: vec![server.url()],
                _server: Some(server),
                _cluster: None,
            }
        }
        Target::Cluster(primaries) => {
            let cluster = RedisCluster::start_with(primaries)?;
            let cpu_urls = cluster
                .nodes()
                .unwrap_or_default()
                .iter()
                .filter(|n| n.primary)
                .map(|n| format!("redis://127.0.0.1:{}", n.port))
                .collect();
            Running {
                url: cluster.url().to_owned(),
                cpu_urls,
                _server: None,
                _cluster: Some(cluster),
            }
        }
    })
}

/// Every target at every load; `progress` gets a line per row.
pub fn run(
    plan: &ThroughputPlan,
    mut progress: impl FnMut(&str),
) -> BenchResult<Vec<ThroughputRow>> {
    let mut rows = Vec::new();
    for &target in &plan.targets {
        let running = start(target)?;
        for &rate in &plan.rates {
            let row = measure(target, &running, rate, plan)?;
            progress(&format!(
                "{}: {} offered, {} delivered a second",
                row.target,
                grouped(rate),
                grouped(row.delivered_per_s.round() as u64)
            ));
            rows.push(row);
        }
    }
    Ok(rows)
}

/// CPU seconds of each server so far.
fn cpu(urls: &[String]) -> BenchResult<Vec<f64>> {
    urls.iter()
        .map(|url| {
            server_cpu_s(url).ok_or_else(|| BenchError::process("redis-server", "INFO cpu failed"))
        })
        .collect()
}

fn measure(
    target: Target,
    running: &Running,
    rate: u64,
    plan: &ThroughputPlan,
) -> BenchResult<ThroughputRow> {
    let channels: Vec<String> = (0..plan.channels.max(1))
        .map(|i| format!("load:{{{i}}}"))
        .collect();
    let stop = Arc::new(AtomicBool::new(false));
    let ready = Arc::new(Barrier::new(plan.subscribers + plan.publishers + 1));
    let received = Arc::new(AtomicU64::new(0));
    let published = Arc::new(AtomicU64::new(0));
    let mut threads = Vec::new();
    for _ in 0..plan.subscribers {
        threads.push(subscriber(
            running.url.clone(),
            channels.clone(),
            (stop.clone(), ready.clone()),
            received.clone(),
        ));
    }
    let per_publisher = rate as f64 / plan.publishers.max(1) as f64;
    for p in 0..plan.publishers {
        threads.push(publisher(
            running.url.clone(),
            channels.clone(),
            ready.clone(),
            published.clone(),
            (p, per_publisher, plan.window, plan.size),
        ));
    }
    ready.wait();
    let (cpu_before, started) = (cpu(&running.cpu_urls)?, Instant::now());
    let publishers: Vec<_> = threads.split_off(plan.subscribers);
    for handle in publishers {
        joined(handle)?;
    }
    let elapsed = started.elapsed().as_secs_f64();
    let cpu_after = cpu(&running.cpu_urls)?;
    stop.store(true, Ordering::Relaxed);
    for handle in threads {
        joined(handle)?;
    }
    let node_pct: Vec<f64> = cpu_before
        .iter()
        .zip(&cpu_after)
        .map(|(before, after)| (after - before) / elapsed * 100.0)
        .collect();
    let delivered_per_s =
        received.load(Ordering::Relaxed) as f64 / plan.subscribers.max(1) as f64 / elapsed;
    Ok(ThroughputRow {
        target: target.name(),
        nodes: node_pct.len(),
        offered_per_s: rate,
        published_per_s: published.load(Ordering::Relaxed) as f64 / elapsed,
        delivered_per_s,
        busiest_node_cpu_pct: node_pct.iter().copied().fold(0.0, f64::max),
        mean_node_cpu_pct: node_pct.iter().sum::<f64>() / node_pct.len().max(1) as f64,
        saturated: delivered_per_s < 0.95 * rate as f64,
    })
}

type LoadThread = std::thread::JoinHandle<Result<(), String>>;

/// A subscriber on every channel, counting into `received` until `stop` and 300 ms of quiet.
fn subscriber(
    url: String,
    channels: Vec<String>,
    (stop, ready): (Arc<AtomicBool>, Arc<Barrier>),
    received: Arc<AtomicU64>,
) -> LoadThread {
    std::thread::spawn(move || {
        let mut transport = seam_transport::open(&url).map_err(|e| e.to_string())?;
        for channel in &channels {
            transport.subscribe(channel).map_err(|e| e.to_string())?;
        }
        ready.wait();
        let mut quiet_since: Option<Instant> = None;
        loop {
            match transport.receive_timeout(Duration::from_millis(20)) {
                Ok(Some(_)) => {
                    received.fetch_add(1, Ordering::Relaxed);
                    quiet_since = None;
                }
                Ok(None) if stop.load(Ordering::Relaxed) => {
                    // Stopped: what is still on its way gets 300 ms of quiet to arrive.
                    let since = *quiet_since.get_or_insert_with(Instant::now);
                    if since.elapsed() > Duration::from_millis(300) {
                        return Ok(());
                    }
                }
                Ok(None) => {}
                Err(e) => return Err(e.to_string()),
            }
        }
    })
}

/// Publisher `p`, at `rate` messages a second for `window`, round robin over the channels
/// from its own place; adds what it published to `published`.
fn publisher(
    url: String,
    channels: Vec<String>,
    ready: Arc<Barrier>,
    published: Arc<AtomicU64>,
    (p, rate, window, size): (usize, f64, Duration, usize),
) -> LoadThread {
    std::thread::spawn(move || {
        let mut transport = seam_transport::open(&url).map_err(|e| e.to_string())?;
        let mut payload = vec![0u8; size.max(8)];
        ready.wait();
        let started = Instant::now();
        let (mut sent, mut next) = (0u64, p);
        while started.elapsed() < window {
            let due = (started.elapsed().as_secs_f64() * rate) as u64;
            if sent >= due {
                std::thread::sleep(Duration::from_micros(200));
                continue;
            }
            payload[..8].copy_from_slice(&sent.to_le_bytes());
            transport
                .publish(&channels[next % channels.len()], &payload)
                .map_err(|e| e.to_string())?;
            next += 1;
            sent += 1;
        }
        published.fetch_add(sent, Ordering::Relaxed);
        Ok(())
    })
}

fn joined(handle: LoadThread) -> BenchResult<()> {
    handle
        .join()
        .map_err(|_| BenchError::process("a load thread", "panicked"))?
        .map_err(|e| BenchError::process("a load thread", e))
}

/// The rows as a table, and per target the largest load carried (not saturated).
pub fn document(rows: &[ThroughputRow]) -> Document {
    let mut table = Table::new(&[
        ("target", Left),
        ("primaries", Right),
        ("offered/s", Right),
        ("published/s", Right),
        ("delivered/s", Right),
        ("busiest node CPU %", Right),
        ("mean node CPU %", Right),
        ("", Left),
    ]);
    for row in rows {
        table.row(vec![
            row.target.clone(),
            row.nodes.to_string(),
            grouped(row.offered_per_s),
            grouped(row.published_per_s.round() as u64),
            grouped(row.delivered_per_s.round() as u64),
            format!("{:.0}", row.busiest_node_cpu_pct),
            format!("{:.0}", row.mean_node_cpu_pct),
            if row.saturated { "saturated" } else { "" }.to_owned(),
        ]);
    }
    let mut doc = Document::new();
    doc.table(table);
    let mut targets: Vec<&str> = rows.iter().map(|r| r.target.as_str()).collect();
    targets.dedup();
    for target in targets {
        let carried = rows
            .iter()
            .filter(|r| r.target == target && !r.saturated)
            .max_by(|a, b| a.delivered_per_s.total_cmp(&b.delivered_per_s));
        doc.line(match carried {
            Some(r) => format!(
                "{target}: carried {} messages a second (offered {}), busiest node at {:.0} % of a \
                 core",
                grouped(r.delivered_per_s.round() as u64),
                grouped(r.offered_per_s),
                r.busiest_node_cpu_pct
            ),
            None => format!("{target}: saturated at every load offered"),
        });
    }
    doc
}
