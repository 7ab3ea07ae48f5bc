//! The subscriber's own socket: non-blocking reads into a buffer the parser borrows from.
//!
//! redis-rs's synchronous `PubSub` can only receive by blocking (a read timeout is the closest it
//! has, and Linux rounds socket timeouts up to a scheduler tick), so the subscribing connection
//! is a plain socket driven here; commands on it are still encoded by redis-rs.

use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::os::fd::{AsFd, BorrowedFd};
use std::os::unix::net::UnixStream;
use std::time::Duration;

use redis::ConnectionAddr;

enum Stream {
    Tcp(TcpStream),
    Unix(UnixStream),
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
    /// Connects to `addr` within `timeout`; the socket is left non-blocking.
    pub(super) fn connect(addr: &ConnectionAddr, timeout: Duration) -> io::Result<Self> {
        let stream = match addr {
            ConnectionAddr::Tcp(host, port) => {
                let mut last = io::Error::new(io::ErrorKind::NotFound, "no address resolved");
                let mut connected = None;
                for candidate in (host.as_str(), *port).to_socket_addrs()? {
                    match TcpStream::connect_timeout(&candidate, timeout) {
                        Ok(stream) => {
                            connected = Some(stream);
                            break;
                        }
                        Err(e) => last = e,
                    }
                }
                let stream = connected.ok_or(last)?;
                stream.set_nodelay(true)?;
                Stream::Tcp(stream)
            }
            ConnectionAddr::Unix(path) => Stream::Unix(UnixStream::connect(path)?),
            _ => {
                return Err(io::Error::new(
                    io::ErrorKind::Unsupported,
                    "TLS connections are not supported by the seam Redis backend",
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
        }
    }

    fn set_read_timeout(&self, timeout: Option<Duration>) -> io::Result<()> {
        match &self.stream {
            Stream::Tcp(s) => s.set_read_timeout(timeout),
            Stream::Unix(s) => s.set_read_timeout(timeout),
        }
    }

    /// Sends a packed command.
    pub(super) fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.set_nonblocking(false)?;
        let result = match &mut self.stream {
            Stream::Tcp(s) => s.write_all(bytes),
            Stream::Unix(s) => s.write_all(bytes),
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
            let read = match &mut self.stream {
                Stream::Tcp(s) => s.read(&mut self.buf[self.end..]),
                Stream::Unix(s) => s.read(&mut self.buf[self.end..]),
            };
            match read {
                Ok(0) => {
                    break Err(io::Error::new(
                        io::ErrorKind::UnexpectedEof,
                        "the server closed the connection",
                    ));
                }
                Ok(n) => {
                    self.end += n;
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
        }
    }
}
