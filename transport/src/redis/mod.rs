//! The Redis backend: `redis://[user:password@]host:port[/db][?max_payload=N&timeout_ms=N&connect_ms=N&reconnect=0|1]`.
//!
//! Two connections per transport, as Redis requires: one made by redis-rs for `PUBLISH`, and one
//! subscribed socket read without blocking (see [`socket`]). Messages carry the seam envelope as
//! their first bytes.
//!
//! # Outages
//!
//! When the server goes away (restarted, or it dropped this client, as Redis does to a slow
//! subscriber past `client-output-buffer-limit pubsub`), the transport does not fail: it counts
//! a disconnect, drops what is published meanwhile (counted in `Stats::dropped_while_down`),
//! receives nothing, and tries to reconnect on the next call after a back-off that starts at
//! 50 ms and doubles up to 250 ms (well inside a neighbour timeout, so pods that reconnect at
//! slightly different moments do not take each other for dead). Once connected it
//! authenticates and subscribes again to every channel and pattern it had. [`Transport::is_connected`] says whether it is up; `Stats` has
//! the disconnects, reconnects and time spent down. A reconnect attempt waits at most
//! `connect_ms` (default 250 ms). `reconnect=0` in the URL turns this off: the first lost
//! connection is then an error.
//! Passwords go to the server only: every address, URL and error this backend prints has them
//! removed.

mod resp;
mod socket;

use std::collections::VecDeque;
use std::ops::Range;
use std::time::{Duration, Instant};

use redis::ConnectionLike;

use crate::envelope::{Envelope, Intake, SeqCounter, random_publisher_id};
use crate::error::{OpenError, PublishError, ReceiveError, SubscribeError};
use crate::{Backend, MAX_CHANNEL_LEN, Message, Stats, Transport, validate_channel};
use resp::{Frame, Item, RespError};
use socket::Socket;

/// Settings of the Redis backend beyond what redis-rs reads from the URL.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RedisConfig {
    /// Largest payload, in bytes, a publish accepts and a receive takes.
    pub max_payload: usize,
    /// Time allowed to connect, and for the server to answer a command.
    pub timeout: Duration,
    /// Whether a lost connection is re-established (see the module docs) or is an error.
    pub reconnect: bool,
    /// Time a reconnect attempt may take.
    pub connect_timeout: Duration,
}

impl Default for RedisConfig {
    fn default() -> Self {
        Self {
            max_payload: 4 << 20,
            timeout: Duration::from_secs(5),
            reconnect: true,
            connect_timeout: Duration::from_millis(250),
        }
    }
}

/// First and longest wait between reconnect attempts.
const BACKOFF: (Duration, Duration) = (Duration::from_millis(50), Duration::from_millis(250));

/// The server, as the URL names it.
struct Endpoint {
    client: redis::Client,
    /// `host:port` or socket path, for messages (never the password).
    addr: String,
    username: Option<String>,
    password: Option<String>,
}

impl Endpoint {
    /// `text` with the password replaced by `***`.
    fn scrub(&self, text: String) -> String {
        match &self.password {
            Some(p) if !p.is_empty() => text.replace(p.as_str(), "***"),
            _ => text,
        }
    }

    /// The publishing connection and the subscriber's socket, each given `timeout` to connect.
    fn connect(
        &self,
        timeout: Duration,
        command_timeout: Duration,
    ) -> Result<(redis::Connection, Socket), OpenError> {
        let publisher = self
            .client
            .get_connection_with_timeout(timeout)
            .map_err(|e| {
                let reason = self.scrub(e.to_string());
                if e.kind() == redis::ErrorKind::AuthenticationFailed
                    || reason.contains("WRONGPASS")
                    || reason.contains("NOAUTH")
                {
                    OpenError::AuthenticationFailed {
                        addr: self.addr.clone(),
                        reason,
                    }
                } else {
                    OpenError::Unreachable {
                        addr: self.addr.clone(),
                        reason,
                    }
                }
            })?;
        let unreachable = |reason: String| OpenError::Unreachable {
            addr: self.addr.clone(),
            reason,
        };
        publisher
            .set_read_timeout(Some(command_timeout))
            .and_then(|()| publisher.set_write_timeout(Some(command_timeout)))
            .map_err(|e| unreachable(e.to_string()))?;
        let info = self.client.get_connection_info();
        let socket =
            Socket::connect(info.addr(), timeout).map_err(|e| unreachable(e.to_string()))?;
        Ok((publisher, socket))
    }
}

/// Since when the server has been unreachable, and when to try again.
struct Outage {
    since: Instant,
    next_attempt: Instant,
    backoff: Duration,
}

/// Whether a redis-rs error means the connection is gone (not a refusal by the server).
fn connection_lost(e: &redis::RedisError) -> bool {
    e.is_io_error() || e.is_connection_dropped() || e.is_connection_refusal() || e.is_timeout()
}

/// A transport over a Redis server.
pub struct RedisTransport {
    config: RedisConfig,
    endpoint: Endpoint,
    /// `host:port` or socket path, for messages (never the password).
    addr: String,
    publisher: redis::Connection,
    out: Vec<u8>,
    publisher_id: u64,
    seqs: SeqCounter,
    socket: Socket,
    /// Messages that arrived while a subscription waited for its confirmation.
    early: VecDeque<EarlyMessage>,
    current: Option<Current>,
    /// Bytes of an oversized reply still to skip.
    discard: usize,
    intake: Intake,
    /// Subscriptions in force, to renew after a reconnect: (`SUBSCRIBE` or `PSUBSCRIBE`, name).
    subscriptions: Vec<(&'static str, String)>,
    /// Set while the server is unreachable.
    outage: Option<Outage>,
}

struct EarlyMessage {
    channel: String,
    pattern: Option<String>,
    payload: Range<usize>,
    wire: Vec<u8>,
}

/// Where the last returned message lives.
enum Current {
    Buffered {
        channel: Range<usize>,
        pattern: Option<Range<usize>>,
        payload: Range<usize>,
    },
    Early(EarlyMessage),
}

/// What a parsed reply is.
enum Reply<'a> {
    Message {
        channel: &'a [u8],
        pattern: Option<&'a [u8]>,
        wire: &'a [u8],
    },
    Confirmation {
        kind: &'a [u8],
        channel: &'a [u8],
    },
    ServerError(&'a [u8]),
    Other,
}

fn classify<'a>(frame: &Frame<'a>) -> Reply<'a> {
    let bulk = |i: usize| match frame.items[i] {
        Item::Bulk(bytes) => Some(bytes),
        _ => None,
    };
    if !frame.is_array {
        return match frame.items[0] {
            Item::Error(text) => Reply::ServerError(text),
            _ => Reply::Other,
        };
    }
    match (frame.len, bulk(0)) {
        (3, Some(b"message")) => match (bulk(1), bulk(2)) {
            (Some(channel), Some(wire)) => Reply::Message {
                channel,
                pattern: None,
                wire,
            },
            _ => Reply::Other,
        },
        (4, Some(b"pmessage")) => match (bulk(1), bulk(2), bulk(3)) {
            (Some(pattern), Some(channel), Some(wire)) => Reply::Message {
                channel,
                pattern: Some(pattern),
                wire,
            },
            _ => Reply::Other,
        },
        (3, Some(kind)) => match bulk(1) {
            Some(channel) => Reply::Confirmation { kind, channel },
            None => Reply::Other,
        },
        _ => Reply::Other,
    }
}

/// Checks a message's envelope and counts it; returns the payload range inside `wire` if valid.
fn accept(intake: &mut Intake, channel: &[u8], wire: &[u8]) -> Option<Range<usize>> {
    match std::str::from_utf8(channel).ok().zip(Envelope::split(wire)) {
        Some((channel, (envelope, payload))) => {
            let key = intake.channel_key(channel);
            intake.accept(key, &envelope);
            Some(range_in(wire, payload))
        }
        None => {
            intake.malformed();
            None
        }
    }
}

/// Offset range of `part` inside `whole` (`part` must be a sub-slice of `whole`).
fn range_in(whole: &[u8], part: &[u8]) -> Range<usize> {
    let start = part.as_ptr() as usize - whole.as_ptr() as usize;
    start..start + part.len()
}

/// Replaces the password of `url` (if any) with `***`.
pub fn redact_url(url: &str) -> String {
    let Some(scheme_end) = url.find("://") else {
        return url.to_owned();
    };
    let rest = &url[scheme_end + 3..];
    let authority_end = rest.find('/').unwrap_or(rest.len());
    match rest[..authority_end].rfind('@') {
        Some(at) => match rest[..at].find(':') {
            Some(colon) => format!(
                "{}{}:***{}",
                &url[..scheme_end + 3],
                &rest[..colon],
                &rest[at..]
            ),
            None => format!("{}***{}", &url[..scheme_end + 3], &rest[at..]),
        },
        None => url.to_owned(),
    }
}

impl RedisTransport {
    /// Connects to the Redis server named by `url`.
    pub fn open(url: &str) -> Result<Self, OpenError> {
        let shown = redact_url(url);
        let invalid = |reason: String| OpenError::InvalidUrl {
            url: shown.clone(),
            reason,
        };
        let (base, query) = url.split_once('?').unwrap_or((url, ""));
        let mut config = RedisConfig::default();
        let mut passed = Vec::new();
        for pair in query.split('&').filter(|p| !p.is_empty()) {
            let (key, value) = pair.split_once('=').unwrap_or((pair, ""));
            let number = || {
                value
                    .parse::<u64>()
                    .ok()
                    .filter(|n| *n > 0)
                    .ok_or_else(|| invalid(format!("`{key}` must be a positive whole number")))
            };
            match key {
                "max_payload" => config.max_payload = number()? as usize,
                "timeout_ms" => config.timeout = Duration::from_millis(number()?),
                "connect_ms" => config.connect_timeout = Duration::from_millis(number()?),
                "reconnect" => {
                    config.reconnect = match value {
                        "1" | "true" => true,
                        "0" | "false" => false,
                        _ => return Err(invalid("`reconnect` must be 0 or 1".to_owned())),
                    }
                }
                _ => passed.push(pair),
            }
        }
        let redis_url = if passed.is_empty() {
            base.to_owned()
        } else {
            format!("{base}?{}", passed.join("&"))
        };
        let client = redis::Client::open(redis_url.as_str()).map_err(|e| invalid(e.to_string()))?;
        let info = client.get_connection_info().clone();
        let endpoint = Endpoint {
            addr: info.addr().to_string(),
            username: info.redis_settings().username().map(str::to_owned),
            password: info.redis_settings().password().map(str::to_owned),
            client,
        };
        let (publisher, socket) = endpoint.connect(config.timeout, config.timeout)?;
        let mut transport = Self {
            config,
            addr: endpoint.addr.clone(),
            endpoint,
            publisher,
            out: Vec::new(),
            publisher_id: random_publisher_id(),
            seqs: SeqCounter::default(),
            socket,
            early: VecDeque::new(),
            current: None,
            discard: 0,
            intake: Intake::default(),
            subscriptions: Vec::new(),
            outage: None,
        };
        transport
            .authenticate()
            .map_err(|reason| OpenError::AuthenticationFailed {
                addr: transport.addr.clone(),
                reason,
            })?;
        Ok(transport)
    }

    /// Authenticates the subscriber's socket, if the URL has a password (redis-rs has done the
    /// publishing connection).
    fn authenticate(&mut self) -> Result<(), String> {
        let Some(password) = self.endpoint.password.clone() else {
            return Ok(());
        };
        let mut auth = redis::cmd("AUTH");
        if let Some(user) = &self.endpoint.username {
            auth.arg(user);
        }
        auth.arg(&password);
        self.command(&auth.get_packed_command(), |reply| match reply {
            Reply::ServerError(text) => Some(Err(String::from_utf8_lossy(text).into())),
            Reply::Other => Some(Ok(())),
            _ => None,
        })
        .map_err(|reason| self.endpoint.scrub(reason))
    }

    /// Notes that the server is unreachable (once per outage) and forgets what was half read.
    fn went_down(&mut self) {
        if self.outage.is_some() {
            return;
        }
        let now = Instant::now();
        self.outage = Some(Outage {
            since: now,
            next_attempt: now + BACKOFF.0,
            backoff: BACKOFF.0,
        });
        self.intake.stats.disconnects += 1;
        self.current = None;
        self.early.clear();
        self.discard = 0;
    }

    /// Whether the server is reachable, reconnecting first if it is down and an attempt is due.
    fn up(&mut self) -> bool {
        let Some(outage) = &self.outage else {
            return true;
        };
        let now = Instant::now();
        if now < outage.next_attempt {
            return false;
        }
        match self.reconnect() {
            Ok(()) => {
                if let Some(outage) = self.outage.take() {
                    self.intake.stats.down_ns += outage.since.elapsed().as_nanos() as u64;
                }
                self.intake.stats.reconnects += 1;
                true
            }
            Err(_) => {
                if let Some(outage) = &mut self.outage {
                    outage.backoff = (outage.backoff * 2).min(BACKOFF.1);
                    outage.next_attempt = Instant::now() + outage.backoff;
                }
                false
            }
        }
    }

    /// Connects again, authenticates and renews every subscription.
    fn reconnect(&mut self) -> Result<(), String> {
        let (publisher, socket) = self
            .endpoint
            .connect(self.config.connect_timeout, self.config.timeout)
            .map_err(|e| e.to_string())?;
        self.publisher = publisher;
        self.socket = socket;
        self.current = None;
        self.early.clear();
        self.discard = 0;
        self.authenticate()?;
        for (command, name) in self.subscriptions.clone() {
            self.confirm(command, &name)?;
        }
        Ok(())
    }

    /// Sends a (un)subscription and waits for the server to confirm it.
    fn confirm(&mut self, command: &str, name: &str) -> Result<(), String> {
        let packed = redis::cmd(command).arg(name).get_packed_command();
        let expected = command.to_ascii_lowercase();
        self.command(&packed, |reply| match reply {
            Reply::Confirmation { kind, channel }
                if *kind == expected.as_bytes() && *channel == name.as_bytes() =>
            {
                Some(Ok(()))
            }
            Reply::ServerError(text) => Some(Err(String::from_utf8_lossy(text).into_owned())),
            _ => None,
        })
    }

    /// Largest reply the subscriber accepts: a message of `max_payload` and its framing.
    fn frame_limit(&self) -> usize {
        self.max_bulk() + 2 * MAX_CHANNEL_LEN + 128
    }

    fn max_bulk(&self) -> usize {
        self.config.max_payload + Envelope::WIRE_LEN
    }

    /// Sends a command on the subscribed socket and reads replies until `answer` recognises
    /// one; messages read meanwhile are kept for later receives.
    fn command(
        &mut self,
        packed: &[u8],
        mut answer: impl FnMut(&Reply<'_>) -> Option<Result<(), String>>,
    ) -> Result<(), String> {
        self.current = None;
        self.socket.send(packed).map_err(|e| e.to_string())?;
        let deadline = Instant::now() + self.config.timeout;
        let (max_bulk, frame_limit) = (self.max_bulk(), self.frame_limit());
        loop {
            if self.discard > 0 {
                self.skip_discarded();
                if self.discard > 0 {
                    self.wait_for_bytes(deadline, frame_limit)?;
                    continue;
                }
            }
            let parsed = resp::parse(self.socket.unparsed(), max_bulk);
            match parsed {
                Ok(Some((frame, used))) => {
                    let reply = classify(&frame);
                    let verdict = answer(&reply);
                    if let Reply::Message {
                        channel,
                        pattern,
                        wire,
                    } = reply
                    {
                        let early = EarlyMessage {
                            channel: String::from_utf8_lossy(channel).into_owned(),
                            pattern: pattern.map(|p| String::from_utf8_lossy(p).into_owned()),
                            payload: 0..wire.len(),
                            wire: wire.to_vec(),
                        };
                        self.early.push_back(early);
                    }
                    self.socket.consume(used);
                    if let Some(verdict) = verdict {
                        return verdict;
                    }
                }
                Ok(None) => self.wait_for_bytes(deadline, frame_limit)?,
                Err(RespError::TooLarge { skip }) => {
                    self.intake.malformed();
                    self.discard = skip;
                }
                Err(RespError::Protocol(what)) => return Err(format!("protocol error: {what}")),
            }
        }
    }

    fn wait_for_bytes(&mut self, deadline: Instant, frame_limit: usize) -> Result<(), String> {
        let now = Instant::now();
        if now >= deadline {
            return Err(format!("no answer within {:?}", self.config.timeout));
        }
        self.socket
            .fill(Some(deadline - now), frame_limit)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }

    fn skip_discarded(&mut self) {
        let n = self.discard.min(self.socket.unparsed().len());
        self.socket.consume(n);
        self.discard -= n;
    }

    /// (Un)subscribes and keeps the list of subscriptions to renew after a reconnect. While
    /// the server is down the change is only recorded: the reconnect makes it.
    fn subscription(&mut self, command: &'static str, name: &str) -> Result<(), SubscribeError> {
        validate_channel(name)?;
        let (kind, adds) = match command {
            "SUBSCRIBE" => ("SUBSCRIBE", true),
            "PSUBSCRIBE" => ("PSUBSCRIBE", true),
            "UNSUBSCRIBE" => ("SUBSCRIBE", false),
            _ => ("PSUBSCRIBE", false),
        };
        let recorded = |list: &mut Vec<(&'static str, String)>| {
            list.retain(|(k, n)| !(*k == kind && n == name));
            if adds {
                list.push((kind, name.to_owned()));
            }
        };
        if self.config.reconnect && !self.up() {
            recorded(&mut self.subscriptions);
            return Ok(());
        }
        match self.confirm(command, name) {
            Ok(()) => {
                recorded(&mut self.subscriptions);
                Ok(())
            }
            Err(_) if self.config.reconnect && self.socket_lost() => {
                self.went_down();
                recorded(&mut self.subscriptions);
                Ok(())
            }
            Err(reason) => Err(SubscribeError::Disconnected {
                addr: self.addr.clone(),
                reason,
            }),
        }
    }

    /// Whether the subscriber's socket is closed (checked after a failed command).
    fn socket_lost(&mut self) -> bool {
        self.socket.fill(None, self.frame_limit()).is_err()
    }

    /// Moves the next valid message into `self.current`; returns whether there was one.
    fn advance(&mut self) -> Result<bool, ReceiveError> {
        match self.advance_connected() {
            Err(_) if self.config.reconnect => {
                self.went_down();
                Ok(false)
            }
            result => result,
        }
    }

    fn advance_connected(&mut self) -> Result<bool, ReceiveError> {
        self.current = None;
        if self.config.reconnect && !self.up() {
            return Ok(false);
        }
        while let Some(mut early) = self.early.pop_front() {
            if let Some(payload) = accept(&mut self.intake, early.channel.as_bytes(), &early.wire) {
                early.payload = payload;
                self.current = Some(Current::Early(early));
                return Ok(true);
            }
        }
        let disconnected = |addr: &str, reason: String| ReceiveError::Disconnected {
            addr: addr.to_owned(),
            reason,
        };
        let (max_bulk, frame_limit) = (self.max_bulk(), self.frame_limit());
        loop {
            if self.discard > 0 {
                self.skip_discarded();
                if self.discard > 0 {
                    match self.socket.fill(None, frame_limit) {
                        Ok(true) => continue,
                        Ok(false) => return Ok(false),
                        Err(e) => return Err(disconnected(&self.addr, e.to_string())),
                    }
                }
            }
            let start = self.socket.start;
            let parsed = match resp::parse(self.socket.unparsed(), max_bulk) {
                Ok(Some((frame, used))) => match classify(&frame) {
                    Reply::Message {
                        channel,
                        pattern,
                        wire,
                    } => {
                        let buf = &self.socket.buf;
                        Ok(Some((
                            used,
                            Some((
                                range_in(buf, channel),
                                pattern.map(|p| range_in(buf, p)),
                                range_in(buf, wire),
                            )),
                        )))
                    }
                    _ => Ok(Some((used, None))),
                },
                Ok(None) => Ok(None),
                Err(e) => Err(e),
            };
            match parsed {
                Ok(Some((used, message))) => {
                    self.socket.consume(used);
                    let Some((channel, pattern, wire)) = message else {
                        continue;
                    };
                    debug_assert!(channel.start >= start);
                    let buf = &self.socket.buf;
                    let payload =
                        accept(&mut self.intake, &buf[channel.clone()], &buf[wire.clone()]);
                    if let Some(payload) = payload {
                        let payload = wire.start + payload.start..wire.start + payload.end;
                        self.current = Some(Current::Buffered {
                            channel,
                            pattern,
                            payload,
                        });
                        return Ok(true);
                    }
                }
                Ok(None) => match self.socket.fill(None, frame_limit) {
                    Ok(true) => {}
                    Ok(false) => return Ok(false),
                    Err(e) => return Err(disconnected(&self.addr, e.to_string())),
                },
                Err(RespError::TooLarge { skip }) => {
                    self.intake.malformed();
                    self.discard = skip;
                }
                Err(RespError::Protocol(what)) => {
                    return Err(disconnected(&self.addr, format!("protocol error: {what}")));
                }
            }
        }
    }

    fn current_message(&self) -> Option<Message<'_>> {
        // Channel names were checked as UTF-8 in `accept`; patterns come from the server as sent.
        fn text(bytes: &[u8]) -> &str {
            std::str::from_utf8(bytes).unwrap_or("")
        }
        match self.current.as_ref()? {
            Current::Buffered {
                channel,
                pattern,
                payload,
            } => {
                let buf = &self.socket.buf;
                Some(Message {
                    channel: text(&buf[channel.clone()]),
                    pattern: pattern.clone().map(|p| text(&buf[p])),
                    payload: &buf[payload.clone()],
                })
            }
            Current::Early(early) => Some(Message {
                channel: &early.channel,
                pattern: early.pattern.as_deref(),
                payload: &early.wire[early.payload.clone()],
            }),
        }
    }
}

impl Transport for RedisTransport {
    fn backend(&self) -> Backend {
        Backend::Redis
    }

    fn publish_with(
        &mut self,
        channel: &str,
        capacity: usize,
        write: &mut dyn FnMut(&mut [u8]) -> Option<usize>,
    ) -> Result<usize, PublishError> {
        validate_channel(channel)?;
        let max = self.config.max_payload;
        if capacity > max {
            return Err(PublishError::PayloadTooLarge { len: capacity, max });
        }
        if self.config.reconnect && !self.up() {
            self.intake.stats.dropped_while_down += 1;
            return Ok(0);
        }
        self.out.clear();
        self.out.resize(Envelope::WIRE_LEN + capacity, 0);
        let written =
            write(&mut self.out[Envelope::WIRE_LEN..]).ok_or(PublishError::WriterAborted)?;
        if written > capacity {
            return Err(PublishError::WriterOverrun { written, capacity });
        }
        self.out.truncate(Envelope::WIRE_LEN + written);
        let seq = self.seqs.next(channel);
        let head: &mut [u8; Envelope::WIRE_LEN] = (&mut self.out[..Envelope::WIRE_LEN])
            .try_into()
            .expect("the buffer starts with room for the envelope");
        Envelope::new(self.publisher_id, seq, written).write_to(head);
        let packed = redis::cmd("PUBLISH")
            .arg(channel)
            .arg(&self.out[..])
            .get_packed_command();
        let reached = match self
            .publisher
            .req_packed_command(&packed)
            .and_then(|value| redis::from_redis_value::<usize>(value).map_err(Into::into))
        {
            Ok(reached) => reached,
            Err(e) if self.config.reconnect && connection_lost(&e) => {
                self.went_down();
                self.intake.stats.dropped_while_down += 1;
                return Ok(0);
            }
            Err(e) => {
                return Err(PublishError::Disconnected {
                    addr: self.addr.clone(),
                    reason: e.to_string(),
                });
            }
        };
        self.intake.stats.published += 1;
        Ok(reached)
    }

    fn subscribe(&mut self, channel: &str) -> Result<(), SubscribeError> {
        self.subscription("SUBSCRIBE", channel)
    }

    fn unsubscribe(&mut self, channel: &str) -> Result<(), SubscribeError> {
        self.subscription("UNSUBSCRIBE", channel)?;
        let key = self.intake.channel_key(channel);
        self.intake.forget_channel(key);
        Ok(())
    }

    fn psubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError> {
        self.subscription("PSUBSCRIBE", pattern)
    }

    fn punsubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError> {
        self.subscription("PUNSUBSCRIBE", pattern)
    }

    fn try_receive(&mut self) -> Result<Option<Message<'_>>, ReceiveError> {
        self.advance()?;
        Ok(self.current_message())
    }

    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<Message<'_>>, ReceiveError> {
        let deadline = Instant::now() + timeout;
        let frame_limit = self.frame_limit();
        while !self.advance()? {
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            if let Some(outage) = &self.outage {
                // Down: sleep until the next reconnect attempt (or the deadline).
                let wake = outage.next_attempt.min(deadline);
                std::thread::sleep(wake.saturating_duration_since(now));
                continue;
            }
            if let Err(e) = self.socket.fill(Some(deadline - now), frame_limit) {
                if !self.config.reconnect {
                    return Err(ReceiveError::Disconnected {
                        addr: self.addr.clone(),
                        reason: e.to_string(),
                    });
                }
                self.went_down();
            }
        }
        Ok(self.current_message())
    }

    fn stats(&self) -> Stats {
        let mut stats = self.intake.stats;
        if let Some(outage) = &self.outage {
            stats.down_ns += outage.since.elapsed().as_nanos() as u64;
        }
        stats
    }

    fn is_connected(&self) -> bool {
        self.outage.is_none()
    }

    fn max_payload(&self) -> usize {
        self.config.max_payload
    }
}

#[cfg(test)]
mod tests {
    use super::redact_url;

    #[test]
    fn passwords_are_redacted() {
        assert_eq!(
            redact_url("redis://user:secret@host:6379/0"),
            "redis://user:***@host:6379/0"
        );
        assert_eq!(
            redact_url("redis://:secret@host:6379"),
            "redis://:***@host:6379"
        );
        assert_eq!(redact_url("redis://secret@host"), "redis://***@host");
        assert_eq!(redact_url("redis://host:6379"), "redis://host:6379");
    }
}
