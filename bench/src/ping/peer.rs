//! The ping exchange over a seam transport, both sides.

use std::process::{Child, Command, Stdio};

use seam_transport::redact_url;

use super::{PingError, PingPlan, PingRow, WaitMode, channels, time_rounds};
use crate::wait::next_message;

/// The peer side: echo `count` messages from `ping` back on `pong`, then wait for the last one.
pub fn run_peer(
    url: &str,
    ping: &str,
    pong: &str,
    count: u64,
    wait: WaitMode,
) -> Result<(), String> {
    let mut transport = seam_transport::open(url).map_err(|e| e.to_string())?;
    transport.subscribe(ping).map_err(|e| e.to_string())?;
    transport
        .publish(pong, b"ready")
        .map_err(|e| e.to_string())?;
    let mut buf = Vec::new();
    for _ in 0..count {
        next_message(transport.as_mut(), wait, &mut buf)?;
        transport.publish(pong, &buf).map_err(|e| e.to_string())?;
    }
    // The measuring side sends one more message once it has read every answer.
    next_message(transport.as_mut(), WaitMode::Block, &mut buf)
}

enum PeerHandle {
    Process(Child),
    Thread(std::thread::JoinHandle<Result<(), String>>),
}

impl PeerHandle {
    fn finish(self) -> Result<(), String> {
        match self {
            PeerHandle::Process(mut child) => {
                let status = child.wait().map_err(|e| e.to_string())?;
                status
                    .success()
                    .then_some(())
                    .ok_or_else(|| format!("exited with {status}"))
            }
            PeerHandle::Thread(handle) => handle.join().map_err(|_| "panicked".to_owned())?,
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
    let peer_error = |reason: String| PingError::Peer {
        transport: shown.clone(),
        reason,
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
        let exe = std::env::current_exe().map_err(|e| peer_error(e.to_string()))?;
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
            .map_err(|e| peer_error(format!("could not start: {e}")))?;
        PeerHandle::Process(child)
    };
    let mut buf = Vec::new();
    next_message(transport.as_mut(), WaitMode::Block, &mut buf).map_err(peer_error)?;
    let payload = vec![0xA5u8; size];
    let (latency, msgs_per_s) = time_rounds(plan.warmup, plan.iterations, || {
        transport
            .publish(&ping, &payload)
            .map_err(|e| e.to_string())?;
        next_message(transport.as_mut(), wait, &mut buf)?;
        if buf.len() == size {
            Ok(())
        } else {
            Err(format!("answered {} bytes to {size}", buf.len()))
        }
    })
    .map_err(peer_error)?;
    transport
        .publish(&ping, b"bye")
        .map_err(|e| transport_error(e.to_string()))?;
    peer.finish().map_err(peer_error)?;
    Ok(PingRow {
        transport: transport.backend().name().to_owned(),
        wait: wait.name(),
        size,
        iterations: plan.iterations,
        latency,
        msgs_per_s,
    })
}
