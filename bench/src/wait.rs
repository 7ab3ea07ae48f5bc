//! How a measuring process waits for the next message: spinning or sleeping.

use std::time::{Duration, Instant};

use seam_transport::Transport;
use serde::Serialize;

use crate::error::{BenchError, BenchResult};

/// How long a measuring side waits for any one answer before giving up on its peer.
pub const ANSWER_TIMEOUT: Duration = Duration::from_secs(10);

/// How a side waits for the next message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum WaitMode {
    /// Spin on shared memory, sleep on Redis (spinning clients would starve the server of CPU
    /// on a small host).
    Auto,
    /// Poll without sleeping: lowest latency, one core per side.
    Spin,
    /// Sleep in the transport until woken.
    Block,
}

impl WaitMode {
    /// The mode `Auto` stands for on `transport`.
    pub fn resolve(self, transport: &str) -> WaitMode {
        match self {
            WaitMode::Auto if transport.starts_with("redis") => WaitMode::Block,
            WaitMode::Auto => WaitMode::Spin,
            other => other,
        }
    }

    /// The name used in tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            WaitMode::Auto => "auto",
            WaitMode::Spin => "spin",
            WaitMode::Block => "block",
        }
    }
}

/// Waits for the next message and copies its payload into `buf`.
pub fn next_message(
    transport: &mut dyn Transport,
    wait: WaitMode,
    buf: &mut Vec<u8>,
) -> BenchResult<()> {
    let deadline = Instant::now() + ANSWER_TIMEOUT;
    let mut polls: u32 = 0;
    loop {
        let message = match wait {
            WaitMode::Block => transport.receive_timeout(ANSWER_TIMEOUT),
            _ => transport.try_receive(),
        }?;
        if let Some(message) = message {
            buf.clear();
            buf.extend_from_slice(message.payload);
            return Ok(());
        }
        polls = polls.wrapping_add(1);
        if (wait == WaitMode::Block || polls.is_multiple_of(4096)) && Instant::now() > deadline {
            return Err(BenchError::Timeout {
                what: "the peer sent no answer".to_owned(),
                waited: ANSWER_TIMEOUT,
            });
        }
    }
}
