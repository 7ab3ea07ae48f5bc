//! The inspector on loopback: a small HTTP/1.1 server for one page and its recording.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use super::{LiveRecording, PageMode, page};
use crate::error::{BenchError, BenchResult};

/// What a server serves.
#[derive(Clone)]
pub enum Served {
    /// A finished recording: the page fetches it once.
    Recording(Arc<Vec<u8>>),
    /// A recording still being written by a run's pods.
    Live(LiveRecording),
}

/// A running server; stops when dropped.
pub struct Server {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Server {
    /// Serves `served` on `bind` (`127.0.0.1:0` picks a free port).
    pub fn start(bind: &str, served: Served) -> BenchResult<Self> {
        let listener = TcpListener::bind(bind).map_err(|e| BenchError::io("listen on", bind, e))?;
        let addr = listener
            .local_addr()
            .map_err(|e| BenchError::io("listen on", bind, e))?;
        listener
            .set_nonblocking(true)
            .map_err(|e| BenchError::io("listen on", bind, e))?;
        let stop = Arc::new(AtomicBool::new(false));
        let html = Arc::new(page(match served {
            Served::Recording(_) => PageMode::Fetch,
            Served::Live(_) => PageMode::Live,
        }));
        let flag = Arc::clone(&stop);
        let thread = std::thread::spawn(move || {
            while !flag.load(Ordering::Relaxed) {
                match listener.accept() {
                    Ok((stream, _)) => {
                        let (served, html) = (served.clone(), Arc::clone(&html));
                        std::thread::spawn(move || {
                            if let Err(e) = answer(stream, &served, &html) {
                                tracing::debug!(target: "seam::inspect", "request: {e}");
                            }
                        });
                    }
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                        std::thread::sleep(Duration::from_millis(20));
                    }
                    Err(e) => {
                        tracing::warn!(target: "seam::inspect", "accept: {e}");
                        std::thread::sleep(Duration::from_millis(100));
                    }
                }
            }
        });
        Ok(Self {
            addr,
            stop,
            thread: Some(thread),
        })
    }

    /// The page's address.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// Largest request head read, bytes.
const MAX_REQUEST: usize = 16 * 1024;

fn answer(mut stream: TcpStream, served: &Served, html: &str) -> std::io::Result<()> {
    stream.set_nonblocking(false)?;
    stream.set_read_timeout(Some(Duration::from_secs(5)))?;
    let mut head = Vec::new();
    let mut buf = [0u8; 2048];
    while !head.windows(4).any(|w| w == b"\r\n\r\n") {
        let n = stream.read(&mut buf)?;
        if n == 0 || head.len() > MAX_REQUEST {
            return Ok(());
        }
        head.extend_from_slice(&buf[..n]);
    }
    let text = String::from_utf8_lossy(&head);
    let mut words = text.split_whitespace();
    let (method, target) = (words.next().unwrap_or(""), words.next().unwrap_or(""));
    if method != "GET" {
        return respond(
            &mut stream,
            "405 Method Not Allowed",
            "text/plain",
            &[],
            b"GET only\n",
        );
    }
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    match path {
        "/" | "/index.html" => respond(
            &mut stream,
            "200 OK",
            "text/html; charset=utf-8",
            &[],
            html.as_bytes(),
        ),
        "/recording" => {
            let from = query
                .split('&')
                .find_map(|kv| kv.strip_prefix("from="))
                .and_then(|v| v.parse::<usize>().ok())
                .unwrap_or(0);
            let (bytes, done) = match served {
                Served::Recording(bytes) => (bytes.get(from..).unwrap_or_default().to_vec(), true),
                Served::Live(live) => live.bytes_from(from),
            };
            let done = if done { "1" } else { "0" };
            respond(
                &mut stream,
                "200 OK",
                "application/octet-stream",
                &[("x-seam-done", done), ("cache-control", "no-store")],
                &bytes,
            )
        }
        _ => respond(
            &mut stream,
            "404 Not Found",
            "text/plain",
            &[],
            b"not here\n",
        ),
    }
}

fn respond(
    stream: &mut TcpStream,
    status: &str,
    kind: &str,
    extra: &[(&str, &str)],
    body: &[u8],
) -> std::io::Result<()> {
    let mut head = format!(
        "HTTP/1.1 {status}\r\ncontent-type: {kind}\r\ncontent-length: {}\r\nconnection: close\r\n",
        body.len()
    );
    for (name, value) in extra {
        head.push_str(&format!("{name}: {value}\r\n"));
    }
    head.push_str("\r\n");
    stream.write_all(head.as_bytes())?;
    stream.write_all(body)?;
    stream.flush()
}
