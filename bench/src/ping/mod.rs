//! `seam ping`: one-way latency between two processes, round trip / 2.
//!
//! The measuring side publishes a payload on `ping:<run>`, the peer (a child process started
//! from this same binary; a thread for `local`) publishes it back on `pong:<run>`, and the round
//! trip is timed with the monotonic clock. Before the timed rounds the peer announces itself in
//! band and warm-up rounds run; after them a last message tells the peer to exit, so no peer
//! closes its transport while its answer is unread.
//!
//! Rows for `iceoryx2` are the floor: the same exchange written directly against iceoryx2
//! publish-subscribe, no seam layer, busy-polling.

mod floor;
mod peer;

use std::time::Instant;

use serde::Serialize;

use crate::document::{Align::*, Document, Table, grouped};
use crate::error::BenchResult;
pub use crate::error::PingError;
use crate::latency::{LatencyRecorder, LatencySummary, micros};
pub use crate::wait::ANSWER_TIMEOUT;
pub use crate::wait::WaitMode;
pub use floor::run_floor_peer;
pub use peer::run_peer;

/// What `seam ping` measures.
pub struct PingPlan {
    /// Transport URLs, in the order given.
    pub transports: Vec<String>,
    /// Payload sizes in bytes.
    pub sizes: Vec<usize>,
    /// Timed round trips per row.
    pub iterations: u64,
    /// Untimed round trips before them.
    pub warmup: u64,
    /// How both sides wait.
    pub wait: WaitMode,
    /// Whether to add the plain-iceoryx2 floor rows.
    pub floor: bool,
}

/// One row of results.
#[derive(Debug, Clone, Serialize)]
pub struct PingRow {
    /// `shm`, `local`, `redis`, or `iceoryx2` for the floor.
    pub transport: String,
    /// What the URL turned on beyond the plain backend: `key`, `signed`, `tls`, joined by `+`;
    /// empty for none (see [`settings_of`]).
    pub settings: String,
    /// How both sides waited.
    pub wait: &'static str,
    /// Payload size in bytes.
    pub size: usize,
    /// Timed round trips.
    pub iterations: u64,
    /// One-way latency percentiles (round trip / 2).
    #[serde(flatten)]
    pub latency: LatencySummary,
    /// One-way messages per second over the timed rounds (2 per round trip).
    pub msgs_per_s: f64,
}

/// Channel names of one row, unique to this process and row.
pub fn channels(row: usize) -> (String, String) {
    let run = format!("{}-{row}", std::process::id());
    (format!("seam-ping:{run}"), format!("seam-pong:{run}"))
}

/// Runs every row of `plan`, calling `progress` before each.
pub fn run(plan: &PingPlan, mut progress: impl FnMut(&str)) -> Result<Vec<PingRow>, PingError> {
    let mut rows = Vec::new();
    let mut row_index = 0;
    for transport in &plan.transports {
        let is_shm = transport == "shm" || transport.starts_with("shm?");
        for &size in &plan.sizes {
            if plan.floor && is_shm {
                progress(&format!("iceoryx2 floor, {size} B"));
                rows.push(floor::measure(transport, size, plan, row_index)?);
                row_index += 1;
            }
            let wait = plan.wait.resolve(transport);
            progress(&format!(
                "{}, {size} B, {}",
                seam_transport::redact_url(transport),
                wait.name()
            ));
            rows.push(peer::measure(transport, size, wait, plan, row_index)?);
            row_index += 1;
        }
    }
    Ok(rows)
}

/// Times `iterations` round trips of `round`, after `warmup` untimed ones.
pub fn time_rounds(
    warmup: u64,
    iterations: u64,
    mut round: impl FnMut() -> BenchResult<()>,
) -> BenchResult<(LatencySummary, f64)> {
    for _ in 0..warmup {
        round()?;
    }
    let mut recorder = LatencyRecorder::default();
    let started = Instant::now();
    for _ in 0..iterations {
        let t0 = Instant::now();
        round()?;
        recorder.record(t0.elapsed().as_nanos() as u64 / 2);
    }
    let elapsed = started.elapsed().as_secs_f64();
    Ok((recorder.summary(), 2.0 * iterations as f64 / elapsed))
}

/// What `seam ping` reports: the rows, then the ratios of p50 one run measured (as text, or as
/// BENCHMARKS.md quotes them with `--markdown`).
pub fn document(rows: &[PingRow]) -> Document {
    let mut table = Table::new(&[
        ("transport", Left),
        ("with", Left),
        ("wait", Left),
        ("size B", Right),
        ("p50 µs", Right),
        ("p99 µs", Right),
        ("p99.9 µs", Right),
        ("max µs", Right),
        ("msgs/s", Right),
    ]);
    for row in rows {
        let with = if row.settings.is_empty() {
            "—".to_owned()
        } else {
            row.settings.clone()
        };
        table.row(vec![
            row.transport.clone(),
            with,
            row.wait.to_owned(),
            row.size.to_string(),
            micros(row.latency.p50_ns),
            micros(row.latency.p99_ns),
            micros(row.latency.p999_ns),
            micros(row.latency.max_ns),
            grouped(row.msgs_per_s.round() as u64),
        ]);
    }
    let mut doc = Document::new();
    doc.table(table);
    doc.line(ratios(rows));
    doc
}

/// What `url` turns on beyond its plain backend: `key` (a frame key), `signed` (a signing key
/// or a keyring), `tls` (`rediss`), joined by `+`; empty for none.
pub fn settings_of(url: &str) -> String {
    let query = url.split_once('?').map_or("", |(_, q)| q);
    let has = |names: &[&str]| {
        query
            .split('&')
            .any(|pair| names.contains(&pair.split('=').next().unwrap_or("")))
    };
    let mut on = Vec::new();
    if has(&["key", "key_file"]) {
        on.push("key");
    }
    if has(&["sign_key", "keyring"]) {
        on.push("signed");
    }
    if url.starts_with("rediss") {
        on.push("tls");
    }
    on.join("+")
}

/// The shm / iceoryx2 and redis / shm ratios of p50 one run measured, one line each (plain
/// rows only: no key, signature or TLS).
fn ratios(rows: &[PingRow]) -> String {
    let mut out = String::new();
    let p50 = |name: &str, size: usize, wait: Option<&str>| {
        rows.iter()
            .find(|r| {
                r.transport == name
                    && r.settings.is_empty()
                    && r.size == size
                    && wait.is_none_or(|w| r.wait == w)
            })
            .map(|r| r.latency.p50_ns as f64)
    };
    let mut sizes: Vec<usize> = rows.iter().map(|r| r.size).collect();
    sizes.sort_unstable();
    sizes.dedup();
    for size in sizes {
        // The floor busy-polls, so it is compared with shm busy-polling only.
        if let (Some(shm), Some(floor)) =
            (p50("shm", size, Some("spin")), p50("iceoryx2", size, None))
        {
            out += &format!("{size} B: shm p50 / iceoryx2 p50 = {:.2}\n", shm / floor);
        }
        if let (Some(redis), Some(shm)) = (p50("redis", size, None), p50("shm", size, None)) {
            out += &format!("{size} B: redis p50 / shm p50 = {:.1}\n", redis / shm);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_name_what_a_url_turns_on() {
        assert_eq!(settings_of("shm"), "");
        assert_eq!(settings_of("shm?prefix=p_&buffer=64"), "");
        assert_eq!(settings_of("shm?key=s"), "key");
        assert_eq!(settings_of("shm?key_file=/k&keyring=/r"), "key+signed");
        assert_eq!(
            settings_of("redis://127.0.0.1:6379?sign_key=/w.key"),
            "signed"
        );
        assert_eq!(settings_of("rediss://127.0.0.1:6380?tls_ca=/ca.pem"), "tls");
        assert_eq!(settings_of("rediss-cluster://h:1?key=s"), "key+tls");
    }
}
