//! The subscriber's own socket: non-blocking reads into a buffer the parser borrows from.
//!
//! redis-rs's synchronous `PubSub` can only receive by blocking (a read timeout is the closest it
//! has, and Linux rounds socket timeouts up to a scheduler tick), so the subscribing connection
//! is a plain socket driven here (TCP, a Unix socket, or TLS over TCP through rustls); commands
//! on it are still encoded by redis-rs.

use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::os::fd::{AsFd, BorrowedFd};
use std::os::unix::net::UnixStream;
use std::time::Duration;

use redis::ConnectionAddr;

use super::tls::Tls;

enum Stream {
    Tcp(TcpStream),
    Unix(UnixStream),
    Tls(Box<rustls::StreamOwned<rustls::ClientConnection, TcpStream>>),
}

/// A connected socket with its read buffer.
pub(super) struct Socket {
    stream: Stream,
    pub(super) buf: Vec<u8>,
    /// First byte not yet parsed.
    pub(super) start: usize,
    /// End of the bytes read.
    pub(super) end: usize,
}

const INITIAL_BUFFER: usize = 64 * 1024;

impl Socket {
    /// Connects to `addr` within `timeout` (a `rediss://` server through `tls`, the
    /// handshake done within it too); the socket is left non-blocking.
    pub(super) fn connect(
        addr: &ConnectionAddr,
        timeout: Duration,
        tls: Option<&Tls>,
    ) -> io::Result<Self> {
        let stream = match addr {
            ConnectionAddr::Tcp(host, port) => Stream::Tcp(tcp(host, *port, timeout)?),
            ConnectionAddr::Unix(path) => Stream::Unix(UnixStream::connect(path)?),
            ConnectionAddr::TcpTls { host, port, .. } => {
                let tls = tls.ok_or_else(|| {
                    io::Error::new(
                        io::ErrorKind::InvalidInput,
                        "a rediss:// server without TLS settings",
                    )
                })?;
                let mut stream =
                    rustls::StreamOwned::new(tls.session(host)?, tcp(host, *port, timeout)?);
                stream.sock.set_read_timeout(Some(timeout))?;
                stream.sock.set_write_timeout(Some(timeout))?;
                while stream.conn.is_handshaking() {
                    stream.conn.complete_io(&mut stream.sock).map_err(|e| {
                        io::Error::new(
                            e.kind(),
                            format!("TLS handshake with {host}:{port} failed: {e}"),
                        )
                    })?;
                }
                stream.sock.set_write_timeout(None)?;
                Stream::Tls(Box::new(stream))
            }
            _ => {
                return Err(io::Error::new(
                    io::ErrorKind::Unsupported,
                    "this kind of connection is not supported by the seam Redis backend",
                ));
            }
        };
        let socket = Self {
            stream,
            buf: vec![0; INITIAL_BUFFER],
            start: 0,
            end: 0,
        };
        socket.set_nonblocking(true)?;
        Ok(socket)
    }

    fn set_nonblocking(&self, on: bool) -> io::Result<()> {
        match &self.stream {
            Stream::Tcp(s) => s.set_nonblocking(on),
            Stream::Unix(s) => s.set_nonblocking(on),
            Stream::Tls(s) => s.sock.set_nonblocking(on),
        }
    }

    fn set_read_timeout(&self, timeout: Option<Duration>) -> io::Result<()> {
        match &self.stream {
            Stream::Tcp(s) => s.set_read_timeout(timeout),
            Stream::Unix(s) => s.set_read_timeout(timeout),
            Stream::Tls(s) => s.sock.set_read_timeout(timeout),
        }
    }

    fn read_some(&mut self) -> io::Result<usize> {
        let buf = &mut self.buf[self.end..];
        match &mut self.stream {
            Stream::Tcp(s) => s.read(buf),
            Stream::Unix(s) => s.read(buf),
            Stream::Tls(s) => s.read(buf),
        }
    }

    /// Sends a packed command.
    pub(super) fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.set_nonblocking(false)?;
        let result = match &mut self.stream {
            Stream::Tcp(s) => s.write_all(bytes),
            Stream::Unix(s) => s.write_all(bytes),
            Stream::Tls(s) => s.write_all(bytes).and_then(|()| s.flush()),
        };
        self.set_nonblocking(true)?;
        result
    }

    /// The bytes read and not yet parsed.
    pub(super) fn unparsed(&self) -> &[u8] {
        &self.buf[self.start..self.end]
    }

    /// Reads what the socket has, waiting up to `wait` if it has nothing (`None`: do not wait).
    /// Returns whether bytes arrived. `frame_limit` bounds how large the buffer may grow.
    pub(super) fn fill(&mut self, wait: Option<Duration>, frame_limit: usize) -> io::Result<bool> {
        if self.start == self.end {
            (self.start, self.end) = (0, 0);
        } else if self.end == self.buf.len() {
            // Make room: move the partial frame to the front, and grow if it already is there.
            if self.start > 0 {
                self.buf.copy_within(self.start..self.end, 0);
                (self.start, self.end) = (0, self.end - self.start);
            } else if self.buf.len() < frame_limit {
                let len = (self.buf.len() * 2).min(frame_limit);
                self.buf.resize(len, 0);
            }
        }
        if self.end == self.buf.len() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "a reply is larger than the read buffer may grow",
            ));
        }
        if let Some(wait) = wait {
            self.set_nonblocking(false)?;
            self.set_read_timeout(Some(wait.max(Duration::from_micros(1))))?;
        }
        let result = loop {
            match self.read_some() {
                Ok(0) => {
                    break Err(io::Error::new(
                        io::ErrorKind::UnexpectedEof,
                        "the server closed the connection",
                    ));
                }
                Ok(n) => {
                    self.end += n;
                    self.drain_tls();
                    break Ok(true);
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) =>
                {
                    break Ok(false);
                }
                Err(e) => break Err(e),
            }
        };
        if wait.is_some() {
            self.set_nonblocking(true)?;
        }
        result
    }

    /// Over TLS, takes in what rustls has decrypted already and the socket holds, so nothing
    /// waits inside rustls while the caller sleeps on the socket's readiness.
    fn drain_tls(&mut self) {
        if !matches!(self.stream, Stream::Tls(_)) || self.set_nonblocking(true).is_err() {
            return;
        }
        while self.end < self.buf.len() {
            match self.read_some() {
                Ok(n) if n > 0 => self.end += n,
                _ => break,
            }
        }
    }

    /// Drops `count` bytes from the front of the unparsed bytes (the caller has checked they
    /// are there).
    pub(super) fn consume(&mut self, count: usize) {
        self.start = (self.start + count).min(self.end);
    }
}

impl AsFd for Socket {
    fn as_fd(&self) -> BorrowedFd<'_> {
        match &self.stream {
            Stream::Tcp(s) => s.as_fd(),
            Stream::Unix(s) => s.as_fd(),
            Stream::Tls(s) => s.sock.as_fd(),
        }
    }
}

/// A TCP connection to `host:port` within `timeout`, without Nagle's delay.
fn tcp(host: &str, port: u16, timeout: Duration) -> io::Result<TcpStream> {
    let mut last = io::Error::new(io::ErrorKind::NotFound, "no address resolved");
    for candidate in (host, port).to_socket_addrs()? {
        match TcpStream::connect_timeout(&candidate, timeout) {
            Ok(stream) => {
                stream.set_nodelay(true)?;
                return Ok(stream);
            }
            Err(e) => last = e,
        }
    }
    Err(last)
}
