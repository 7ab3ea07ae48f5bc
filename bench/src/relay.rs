//! A TCP relay with a configurable delay: how a simulated host reaches the Redis server, and how
//! a run puts network latency between hosts on a kernel without `netem`.
//!
//! Each accepted connection is paired with one to the upstream address; each direction is a
//! reader thread that stamps every chunk it reads with the moment it may leave (now + delay +
//! a uniform jitter, never before the chunk ahead of it, so the byte stream keeps its order)
//! and a writer thread that sends it then. With no delay, chunks go straight through.

use std::io::{Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::error::{BenchError, BenchResult};

/// One-way delay a relay adds to every byte, in each direction.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Delay {
    /// Fixed part.
    pub base: Duration,
    /// Up to this much more, uniformly at random per chunk (order is kept).
    pub jitter: Duration,
}

impl Delay {
    /// No delay.
    pub const NONE: Delay = Delay {
        base: Duration::ZERO,
        jitter: Duration::ZERO,
    };

    /// Whether it adds nothing.
    pub fn is_none(&self) -> bool {
        self.base.is_zero() && self.jitter.is_zero()
    }
}

/// A running relay; stops (and closes its connections) when dropped.
pub struct Relay {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    accept: Option<JoinHandle<()>>,
    bytes: Arc<AtomicU64>,
}

impl Relay {
    /// Listens on `listen` (port 0: any free port) and relays each connection to `upstream`
    /// with `delay` each way.
    pub fn start(listen: SocketAddr, upstream: SocketAddr, delay: Delay) -> BenchResult<Self> {
        let listener = TcpListener::bind(listen)
            .map_err(|e| BenchError::io("listen on", listen, e).within("relay"))?;
        let addr = listener
            .local_addr()
            .map_err(|e| BenchError::io("read", "its local address", e).within("relay"))?;
        listener
            .set_nonblocking(true)
            .map_err(|e| BenchError::io("set up", "its socket", e).within("relay"))?;
        let stop = Arc::new(AtomicBool::new(false));
        let bytes = Arc::new(AtomicU64::new(0));
        let accept = {
            let (stop, bytes) = (Arc::clone(&stop), Arc::clone(&bytes));
            std::thread::Builder::new()
                .name("relay-accept".into())
                .spawn(move || accept_loop(&listener, upstream, delay, &stop, &bytes))
                .map_err(|e| BenchError::io("start", "its thread", e).within("relay"))?
        };
        Ok(Self {
            addr,
            stop,
            accept: Some(accept),
            bytes,
        })
    }

    /// The address it listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Bytes relayed so far, both directions.
    pub fn bytes(&self) -> u64 {
        self.bytes.load(Ordering::Relaxed)
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(accept) = self.accept.take() {
            let _ = accept.join();
        }
    }
}

fn accept_loop(
    listener: &TcpListener,
    upstream: SocketAddr,
    delay: Delay,
    stop: &Arc<AtomicBool>,
    bytes: &Arc<AtomicU64>,
) {
    let mut pairs: Vec<(TcpStream, TcpStream)> = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((client, _)) => {
                let Ok(server) = TcpStream::connect_timeout(&upstream, Duration::from_secs(2))
                else {
                    continue;
                };
                let _ = client.set_nonblocking(false);
                let _ = (client.set_nodelay(true), server.set_nodelay(true));
                let (Ok(c2), Ok(s2)) = (client.try_clone(), server.try_clone()) else {
                    continue;
                };
                pump(c2, server.try_clone().ok(), delay, stop, bytes);
                pump(s2, client.try_clone().ok(), delay, stop, bytes);
                pairs.push((client, server));
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(_) => std::thread::sleep(Duration::from_millis(20)),
        }
    }
    // Closing both ends ends every pump.
    for (client, server) in pairs {
        let _ = client.shutdown(Shutdown::Both);
        let _ = server.shutdown(Shutdown::Both);
    }
}

/// Copies `from` to `to` with `delay`, on its own threads, until either side closes.
fn pump(
    mut from: TcpStream,
    to: Option<TcpStream>,
    delay: Delay,
    stop: &Arc<AtomicBool>,
    bytes: &Arc<AtomicU64>,
) {
    let Some(mut to) = to else { return };
    let (bytes, stop) = (Arc::clone(bytes), Arc::clone(stop));
    if delay.is_none() {
        std::thread::spawn(move || {
            let mut buf = vec![0u8; 64 * 1024];
            while let Ok(n) = from.read(&mut buf) {
                if n == 0 || stop.load(Ordering::Relaxed) || to.write_all(&buf[..n]).is_err() {
                    break;
                }
                bytes.fetch_add(n as u64, Ordering::Relaxed);
            }
            let _ = to.shutdown(Shutdown::Write);
        });
        return;
    }
    let (chunks, due) = mpsc::channel::<(Instant, Vec<u8>)>();
    std::thread::spawn(move || {
        let mut rng = Jitter::new();
        let mut last = Instant::now();
        let mut buf = vec![0u8; 64 * 1024];
        while let Ok(n) = from.read(&mut buf) {
            if n == 0 || stop.load(Ordering::Relaxed) {
                break;
            }
            let at = (Instant::now() + delay.base + rng.upto(delay.jitter)).max(last);
            last = at;
            if chunks.send((at, buf[..n].to_vec())).is_err() {
                break;
            }
        }
    });
    std::thread::spawn(move || {
        for (at, chunk) in due {
            let now = Instant::now();
            if at > now {
                std::thread::sleep(at - now);
            }
            if to.write_all(&chunk).is_err() {
                break;
            }
            bytes.fetch_add(chunk.len() as u64, Ordering::Relaxed);
        }
        let _ = to.shutdown(Shutdown::Write);
    });
}

/// A small xorshift generator for jitter (no cryptographic need).
struct Jitter(u64);

impl Jitter {
    fn new() -> Self {
        let seed = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(1, |d| d.as_nanos() as u64)
            | 1;
        Self(seed)
    }

    fn upto(&mut self, max: Duration) -> Duration {
        if max.is_zero() {
            return Duration::ZERO;
        }
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        max.mul_f64((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An echo server on loopback: returns its address.
    fn echo() -> SocketAddr {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let addr = listener.local_addr().expect("addr");
        std::thread::spawn(move || {
            for stream in listener.incoming().flatten() {
                std::thread::spawn(move || {
                    let mut stream = stream;
                    let mut buf = [0u8; 4096];
                    while let Ok(n) = stream.read(&mut buf) {
                        if n == 0 || stream.write_all(&buf[..n]).is_err() {
                            break;
                        }
                    }
                });
            }
        });
        addr
    }

    fn round_trip(relay: &Relay) -> Duration {
        let mut stream = TcpStream::connect(relay.addr()).expect("connect");
        let mut reply = [0u8; 5];
        // The first exchange also pays the connection set-up: time the second.
        stream.write_all(b"hello").expect("write");
        stream.read_exact(&mut reply).expect("read");
        let started = Instant::now();
        stream.write_all(b"again").expect("write");
        stream.read_exact(&mut reply).expect("read");
        assert_eq!(&reply, b"again");
        started.elapsed()
    }

    #[test]
    fn relays_bytes_in_order_and_adds_its_delay_each_way() {
        let upstream = echo();
        let any = "127.0.0.1:0".parse().expect("addr");
        let plain = Relay::start(any, upstream, Delay::NONE).expect("relay");
        let delayed = Relay::start(
            any,
            upstream,
            Delay {
                base: Duration::from_millis(20),
                jitter: Duration::from_millis(5),
            },
        )
        .expect("relay");
        let fast = round_trip(&plain);
        let slow = round_trip(&delayed);
        // Two crossings of the relay, 20 to 25 ms each; a generous upper bound for a busy host.
        assert!(
            slow >= Duration::from_millis(40) && slow < Duration::from_millis(400),
            "{slow:?}"
        );
        assert!(fast < slow, "{fast:?} vs {slow:?}");
        // Order is kept under jitter: many small writes come back in order.
        let mut stream = TcpStream::connect(delayed.addr()).expect("connect");
        let sent: Vec<u8> = (0..200u8).collect();
        for byte in &sent {
            stream.write_all(&[*byte]).expect("write");
        }
        let mut back = vec![0u8; sent.len()];
        stream.read_exact(&mut back).expect("read");
        assert_eq!(back, sent);
        // The relay counts a chunk after writing it, so the last echo may be read first.
        let counted = Instant::now() + Duration::from_secs(2);
        while delayed.bytes() < 400 && Instant::now() < counted {
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(delayed.bytes() >= 400, "{}", delayed.bytes());
    }
}
