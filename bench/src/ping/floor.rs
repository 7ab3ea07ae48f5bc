//! The floor: the ping exchange written directly against iceoryx2, no seam layer.
//!
//! Same services as seam's shm backend would make (one `[u8]` publish-subscribe service per
//! direction, the same buffer size), no envelope, no wake-up events, busy-polling: what
//! iceoryx2 itself costs, for seam's shm backend to be held against.

use std::process::{Command, Stdio};
use std::time::Instant;

use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;

use super::{ANSWER_TIMEOUT, PingError, PingPlan, PingRow, channels, time_rounds};
use crate::error::{BenchError, BenchResult};

type Ipc = ipc::Service;

/// An iceoryx2 error of the floor (its types differ per call; what they say is kept).
fn iox(e: impl std::fmt::Display) -> BenchError {
    BenchError::process("iceoryx2 floor", e)
}

struct FloorPorts {
    _node: Node<Ipc>,
    publisher: Publisher<Ipc, [u8], ()>,
    subscriber: Subscriber<Ipc, [u8], ()>,
}

fn floor_config() -> BenchResult<iceoryx2::config::Config> {
    let mut config = iceoryx2::config::Config::default();
    config.global.prefix = FileName::new(b"seam_floor_").map_err(|e| iox(format!("{e:?}")))?;
    Ok(config)
}

fn ports(publish_on: &str, subscribe_to: &str, size: usize) -> BenchResult<FloorPorts> {
    set_log_level_from_env_or(LogLevel::Fatal);
    let node = NodeBuilder::new()
        .config(&floor_config()?)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<Ipc>()
        .map_err(iox)?;
    let service = |name: &str| {
        let name = ServiceName::new(name).map_err(|e| iox(format!("{e:?}")))?;
        node.service_builder(&name)
            .publish_subscribe::<[u8]>()
            .subscriber_max_buffer_size(16)
            .enable_safe_overflow(true)
            .open_or_create()
            .map_err(iox)
    };
    let publisher = service(publish_on)?
        .publisher_builder()
        .initial_max_slice_len(size.max(8))
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .map_err(iox)?;
    let subscriber = service(subscribe_to)?
        .subscriber_builder()
        .buffer_size(16)
        .create()
        .map_err(iox)?;
    Ok(FloorPorts {
        _node: node,
        publisher,
        subscriber,
    })
}

impl FloorPorts {
    fn send(&self, payload: &[u8]) -> BenchResult<()> {
        let sample = self
            .publisher
            .loan_slice_uninit(payload.len())
            .map_err(iox)?;
        sample
            .write_from_slice(payload)
            .send()
            .map(|_| ())
            .map_err(iox)
    }

    /// Busy-polls for the next sample and copies it into `buf`.
    fn next(&self, buf: &mut Vec<u8>) -> BenchResult<()> {
        let deadline = Instant::now() + ANSWER_TIMEOUT;
        let mut polls: u32 = 0;
        loop {
            if let Some(sample) = self.subscriber.receive().map_err(iox)? {
                buf.clear();
                buf.extend_from_slice(sample.payload());
                return Ok(());
            }
            polls = polls.wrapping_add(1);
            if polls.is_multiple_of(4096) && Instant::now() > deadline {
                return Err(BenchError::Timeout {
                    what: "the peer sent no answer".to_owned(),
                    waited: ANSWER_TIMEOUT,
                });
            }
        }
    }
}

/// The floor's peer side (a child process).
pub fn run_floor_peer(ping: &str, pong: &str, size: usize, count: u64) -> BenchResult<()> {
    let ports = ports(pong, ping, size)?;
    ports.send(b"ready")?;
    let mut buf = Vec::new();
    for _ in 0..count {
        ports.next(&mut buf)?;
        ports.send(&buf)?;
    }
    ports.next(&mut buf)
}

/// The floor's measuring side of one row.
pub(super) fn measure(
    url: &str,
    size: usize,
    plan: &PingPlan,
    row: usize,
) -> Result<PingRow, PingError> {
    let error = |reason: BenchError| PingError::Peer {
        transport: format!("iceoryx2 floor beside {url}"),
        reason: reason.to_string(),
    };
    let (ping, pong) = channels(row);
    let ports = ports(&ping, &pong, size).map_err(error)?;
    let count = plan.warmup + plan.iterations;
    let exe = std::env::current_exe().map_err(|e| error(BenchError::io("run", "the peer", e)))?;
    let mut child = Command::new(exe)
        .args(["ping-floor-peer", "--ping", &ping, "--pong", &pong])
        .args(["--size", &size.to_string(), "--count", &count.to_string()])
        .stdin(Stdio::null())
        .spawn()
        .map_err(|e| error(BenchError::io("start", "the peer", e)))?;
    let mut buf = Vec::new();
    ports.next(&mut buf).map_err(error)?;
    let payload = vec![0xA5u8; size];
    let (latency, msgs_per_s) = time_rounds(plan.warmup, plan.iterations, || {
        ports.send(&payload)?;
        ports.next(&mut buf)
    })
    .map_err(error)?;
    ports.send(b"bye").map_err(error)?;
    let status = child
        .wait()
        .map_err(|e| error(BenchError::io("run", "the peer", e)))?;
    if !status.success() {
        return Err(error(BenchError::process(
            "the peer",
            format!("exited with {status}"),
        )));
    }
    Ok(PingRow {
        transport: "iceoryx2".to_owned(),
        settings: String::new(),
        wait: "spin",
        size,
        iterations: plan.iterations,
        latency,
        msgs_per_s,
    })
}
