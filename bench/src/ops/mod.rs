//! `seam ops`: how long a routed op takes between two processes, stage by stage, with no tick
//! wait in the way.
//!
//! The issuing side (this process) builds a batch of impulses as [`RoutedOp`]s, each stamped
//! when made, and publishes them as one `PhysicsEventsFrame` stamped when handed to the
//! transport, on the owner's `physics_events` channel. The owner (a child process) takes the
//! frame, stamps it, decodes it straight from the received bytes, applies every op to its
//! `ClusterSim` at once, stamping each, and acknowledges; the next batch goes out after the
//! acknowledgement. Stamps are `CLOCK_MONOTONIC`, shared by both processes. The owner reports
//! the stages at the end:
//!
//! - queue: issued → published (building the rest of the batch),
//! - transport: published → received. "Published" is stamped as the publish call starts, inside
//!   the frame it stamps, so encoding the frame into the transport's buffer counts here (about
//!   10 µs for 256 ops); with one op per frame it is negligible.
//! - apply: received → applied (decoding and applying, up to this op),
//! - whole: issued → applied.

mod owner;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Instant;

use seam_proxy::monotonic_ns;
use seam_sim::wire::{
    self, ClusterId, EntityId, OpAck, PhysicsEventsFrame, PhysicsOp, RoutedOp, Stage,
};
use seam_transport::redact_url;
use serde::{Deserialize, Serialize};

use crate::document::{Align::*, Document, Table, grouped};
use crate::error::{BenchError, BenchResult};
use crate::latency::{LatencySummary, micros};
use crate::wait::{WaitMode, next_message};
pub use owner::run_owner;

/// The entity every op targets (the owner spawns it).
pub const TARGET: EntityId = EntityId(uuid_from(1));

/// A pod's first op number: microseconds of the wall clock at its start (late 2026), so the
/// numbers take as many bytes as a pod's.
const FIRST_SEQ: u64 = 1_796_000_000_000_000;

const fn uuid_from(n: u128) -> uuid::Uuid {
    uuid::Uuid::from_u128(n)
}

/// What `seam ops` measures.
pub struct OpsPlan {
    /// Transport URLs.
    pub transports: Vec<String>,
    /// Ops per frame.
    pub batches: Vec<usize>,
    /// Without and with answers in each frame (one per op of the batch).
    pub acks: Vec<bool>,
    /// Timed frames per row.
    pub rounds: u64,
    /// Untimed frames before them.
    pub warmup: u64,
    /// How both sides wait.
    pub wait: WaitMode,
}

/// What the owner measured, sent back as one JSON line.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct StageReport {
    /// Ops applied in timed frames.
    pub ops: u64,
    /// issued → applied.
    pub whole: LatencySummary,
    /// issued → published.
    pub queue: LatencySummary,
    /// published → received.
    pub transport: LatencySummary,
    /// received → applied.
    pub apply: LatencySummary,
}

/// One row of results.
#[derive(Debug, Clone, Serialize)]
pub struct OpsRow {
    /// `shm`, `local` or `redis`.
    pub transport: String,
    /// How both sides waited.
    pub wait: &'static str,
    /// Ops per frame.
    pub batch: usize,
    /// Answers each frame carried.
    pub acks: usize,
    /// Timed frames.
    pub rounds: u64,
    /// p50 of the whole (issued → applied), ns.
    pub p50_ns: u64,
    /// p99 of the whole, ns.
    pub p99_ns: u64,
    /// p99.9 of the whole, ns.
    pub p999_ns: u64,
    /// Ops applied per second over the timed frames (one frame in flight at a time).
    pub ops_per_s: f64,
    /// Every stage.
    pub stages: StageReport,
}

/// Runs every (transport, batch) row, calling `progress` before each.
pub fn run(plan: &OpsPlan, mut progress: impl FnMut(&str)) -> BenchResult<Vec<OpsRow>> {
    let mut rows = Vec::new();
    for transport in &plan.transports {
        let wait = plan.wait.resolve(transport);
        for &batch in &plan.batches {
            for &with_acks in &plan.acks {
                let acks = if with_acks { batch } else { 0 };
                progress(&format!(
                    "{}, batch {batch}, {acks} acks, {}",
                    redact_url(transport),
                    wait.name()
                ));
                rows.push(measure(transport, (batch, acks), wait, plan, rows.len())?);
            }
        }
    }
    Ok(rows)
}

/// A frame of `batch` ops carrying `acks` answers, numbered as a pod numbers them.
fn batch_frame(batch: usize, acks: usize) -> PhysicsEventsFrame {
    PhysicsEventsFrame {
        incarnation: 0,
        from: ClusterId::random(),
        tick: 0,
        stage: Stage::AfterStep,
        published_ns: 0,
        ops: Vec::with_capacity(batch),
        // Answers to as many ops of the other side, numbered as a pod numbers its ops: one
        // run of consecutive numbers, as a pod answers a batch.
        acks: (acks > 0)
            .then(|| OpAck {
                seq: FIRST_SEQ,
                more: (acks - 1) as u16,
                issuer: None,
                done: true,
            })
            .into_iter()
            .collect(),
        contacts: Vec::new(),
        impulses: Vec::new(),
        own_writes: Vec::new(),
        leaving: false,
        unmodelled: Vec::new(),
    }
}

/// `frame`'s ops made round `round`'s batch of `batch` impulses.
fn fill_batch(frame: &mut PhysicsEventsFrame, round: u64, batch: usize) {
    frame.ops.clear();
    for i in 0..batch as u64 {
        frame.ops.push(RoutedOp {
            op: PhysicsOp::Impulse {
                target: TARGET,
                impulse: [1e-3, 0.0, 0.0],
            },
            seq: FIRST_SEQ + round * batch as u64 + i,
            issuer: None,
            issued_ns: monotonic_ns(),
            issued_tick: round,
            age_ticks: 0,
        });
    }
}

fn measure(
    url: &str,
    (batch, acks): (usize, usize),
    wait: WaitMode,
    plan: &OpsPlan,
    row: usize,
) -> BenchResult<OpsRow> {
    let shown = redact_url(url);
    let fail =
        |what: &str, e: &dyn std::fmt::Display| BenchError::process(&shown, format!("{what}: {e}"));
    let mut transport = seam_transport::open(url).map_err(|e| fail("open", &e))?;
    let owner = ClusterId::random();
    let events = seam_proxy::physics_events(owner);
    let ack = format!("seam-ops-ack:{}-{row}", std::process::id());
    transport
        .subscribe(&ack)
        .map_err(|e| fail("subscribe", &e))?;
    let exe = std::env::current_exe().map_err(|e| fail("peer", &e))?;
    let mut child = Command::new(exe)
        .args([
            "ops-owner",
            "--transport",
            url,
            "--events",
            &events,
            "--ack",
            &ack,
        ])
        .args(["--wait", wait.name()])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| fail("cannot start the owner", &e))?;
    let mut buf = Vec::new();
    next_message(transport.as_mut(), WaitMode::Block, &mut buf).map_err(|e| fail("owner", &e))?;

    let mut frame = batch_frame(batch, acks);
    let mut started = Instant::now();
    for round in 0..plan.warmup + plan.rounds {
        if round == plan.warmup {
            started = Instant::now();
        }
        // Frames tagged 1 are timed; warm-up frames are tagged 0.
        frame.tick = u64::from(round >= plan.warmup);
        fill_batch(&mut frame, round, batch);
        // Sized for the largest stamp (varints grow with the value); stamped at the send.
        frame.published_ns = u64::MAX;
        let len = wire::encoded_len(&frame);
        transport
            .publish_with(&events, len, &mut |out| {
                frame.published_ns = monotonic_ns();
                wire::encode_into(&frame, out).ok()
            })
            .map_err(|e| fail("publish", &e))?;
        next_message(transport.as_mut(), wait, &mut buf).map_err(|e| fail("owner", &e))?;
    }
    let elapsed = started.elapsed().as_secs_f64();
    transport
        .publish(&events, owner::STOP)
        .map_err(|e| fail("publish", &e))?;
    let mut line = String::new();
    let stdout = child
        .stdout
        .take()
        .ok_or_else(|| fail("owner", &"no stdout"))?;
    BufReader::new(stdout)
        .read_line(&mut line)
        .map_err(|e| fail("owner report", &e))?;
    let status = child.wait().map_err(|e| fail("owner", &e))?;
    if !status.success() {
        return Err(fail("owner", &format!("exited with {status}")));
    }
    let stages: StageReport =
        serde_json::from_str(&line).map_err(|e| fail("owner report", &format!("{e}: {line:?}")))?;
    Ok(OpsRow {
        transport: transport.backend().name().to_owned(),
        wait: wait.name(),
        batch,
        acks,
        rounds: plan.rounds,
        p50_ns: stages.whole.p50_ns,
        p99_ns: stages.whole.p99_ns,
        p999_ns: stages.whole.p999_ns,
        ops_per_s: stages.ops as f64 / elapsed,
        stages,
    })
}

/// What `seam ops` reports: the rows (times in µs; xport = published → received), then the
/// ratios one run measured (as text, or as BENCHMARKS.md quotes them with `--markdown`).
pub fn document(rows: &[OpsRow]) -> Document {
    let mut table = Table::new(&[
        ("transport", Left),
        ("wait", Left),
        ("batch", Right),
        ("acks", Right),
        ("whole p50", Right),
        ("p99", Right),
        ("p99.9", Right),
        ("queue p50", Right),
        ("xport p50", Right),
        ("xport p99", Right),
        ("apply p50", Right),
        ("ops/s", Right),
    ]);
    for r in rows {
        let s = &r.stages;
        table.row(vec![
            r.transport.clone(),
            r.wait.to_owned(),
            r.batch.to_string(),
            r.acks.to_string(),
            micros(r.p50_ns),
            micros(r.p99_ns),
            micros(r.p999_ns),
            micros(s.queue.p50_ns),
            micros(s.transport.p50_ns),
            micros(s.transport.p99_ns),
            micros(s.apply.p50_ns),
            grouped(r.ops_per_s.round() as u64),
        ]);
    }
    let mut doc = Document::new();
    doc.table(table);
    doc.line("times in µs; xport = published → received");
    doc.line(ratios(rows));
    doc
}

/// The redis / shm ratio of the transport stage's p50 per batch (frames without answers), and
/// per transport and batch the ratio with answers to without, one line each.
fn ratios(rows: &[OpsRow]) -> String {
    let mut out = String::new();
    let mut batches: Vec<usize> = rows.iter().map(|r| r.batch).collect();
    batches.sort_unstable();
    batches.dedup();
    // Rows measured more than once (`--acks off,on,off,on`): the median of their p50s, so
    // drift on a shared machine weighs on both sides alike.
    let p50 = |name: &str, batch: usize, acked: bool| {
        let mut p50s: Vec<f64> = rows
            .iter()
            .filter(|r| r.transport == name && r.batch == batch && (r.acks > 0) == acked)
            .map(|r| r.stages.transport.p50_ns as f64)
            .collect();
        p50s.sort_by(f64::total_cmp);
        p50s.get(p50s.len() / 2).copied()
    };
    for &batch in &batches {
        let acked = rows.iter().all(|r| r.acks > 0);
        if let (Some(redis), Some(shm)) = (p50("redis", batch, acked), p50("shm", batch, acked)) {
            out += &format!(
                "batch {batch}: transport stage p50 redis / shm = {:.1}\n",
                redis / shm
            );
        }
    }
    for name in ["shm", "local", "redis"] {
        for &batch in &batches {
            if let (Some(with), Some(without)) = (p50(name, batch, true), p50(name, batch, false)) {
                out += &format!(
                    "{name} batch {batch}: transport stage p50 with acks / without = {:.2}\n",
                    with / without
                );
            }
        }
    }
    out
}
