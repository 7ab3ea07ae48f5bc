//! The ping exchange over a seam transport, both sides.

use std::process::{Child, Command, Stdio};

use seam_transport::redact_url;

use super::{PingError, PingPlan, PingRow, WaitMode, channels, time_rounds};
use crate::error::{BenchError, BenchResult};
use crate::wait::next_message;

/// The peer side: echo `count` messages from `ping` back on `pong`, then wait for the last one.
pub fn run_peer(url: &str, ping: &str, pong: &str, count: u64, wait: WaitMode) -> BenchResult<()> {
    let mut transport = seam_transport::open(url)?;
    transport.subscribe(ping)?;
    transport.publish(pong, b"ready")?;
    let mut buf = Vec::new();
    for _ in 0..count {
        next_message(transport.as_mut(), wait, &mut buf)?;
        transport.publish(pong, &buf)?;
    }
    // The measuring side sends one more message once it has read every answer.
    next_message(transport.as_mut(), WaitMode::Block, &mut buf)
}

enum PeerHandle {
    Process(Child),
    Thread(std::thread::JoinHandle<BenchResult<()>>),
}

impl PeerHandle {
    fn finish(self) -> BenchResult<()> {
        match self {
            PeerHandle::Process(mut child) => {
                let status = child
                    .wait()
                    .map_err(|e| BenchError::io("wait for", "the peer", e))?;
                status
                    .success()
                    .then_some(())
                    .ok_or_else(|| BenchError::process("the peer", format!("exited with {status}")))
            }
            PeerHandle::Thread(handle) => handle
                .join()
                .map_err(|_| BenchError::process("the peer thread", "panicked"))?,
        }
    }
}

/// The measuring side of one row.
pub(super) fn measure(
    url: &str,
    size: usize,
    wait: WaitMode,
    plan: &PingPlan,
    row: usize,
) -> Result<PingRow, PingError> {
    let shown = redact_url(url);
    let transport_error = |reason: String| PingError::Transport {
        transport: shown.clone(),
        reason,
    };
    let peer_error = |reason: BenchError| PingError::Peer {
        transport: shown.clone(),
        reason: reason.to_string(),
    };
    let mut transport = seam_transport::open(url).map_err(|e| transport_error(e.to_string()))?;
    let (ping, pong) = channels(row);
    transport
        .subscribe(&pong)
        .map_err(|e| transport_error(e.to_string()))?;
    let count = plan.warmup + plan.iterations;
    let peer = if transport.backend() == seam_transport::Backend::Local {
        // iceoryx2's local services live inside one process: the peer is a thread.
        let (url, ping, pong) = (url.to_owned(), ping.clone(), pong.clone());
        PeerHandle::Thread(std::thread::spawn(move || {
            run_peer(&url, &ping, &pong, count, wait)
        }))
    } else {
        let exe = std::env::current_exe()
            .map_err(|e| peer_error(BenchError::io("find", "seam itself", e)))?;
        let child = Command::new(exe)
            .args([
                "ping-peer",
                "--transport",
                url,
                "--ping",
                &ping,
                "--pong",
                &pong,
            ])
            .args(["--count", &count.to_string(), "--wait", wait.name()])
            .stdin(Stdio::null())
            .spawn()
            .map_err(|e| peer_error(BenchError::io("start", "the peer", e)))?;
        PeerHandle::Process(child)
    };
    let mut buf = Vec::new();
    next_message(transport.as_mut(), WaitMode::Block, &mut buf).map_err(peer_error)?;
    let payload = vec![0xA5u8; size];
    let (latency, msgs_per_s) = time_rounds(plan.warmup, plan.iterations, || {
        transport.publish(&ping, &payload)?;
        next_message(transport.as_mut(), wait, &mut buf)?;
        if buf.len() == size {
            Ok(())
        } else {
            Err(BenchError::process(
                "the peer",
                format!("answered {} bytes to {size}", buf.len()),
            ))
        }
    })
    .map_err(peer_error)?;
    transport
        .publish(&ping, b"bye")
        .map_err(|e| transport_error(e.to_string()))?;
    peer.finish().map_err(peer_error)?;
    Ok(PingRow {
        transport: transport.backend().name().to_owned(),
        settings: super::settings_of(url),
        wait: wait.name(),
        size,
        iterations: plan.iterations,
        latency,
        msgs_per_s,
    })
}
