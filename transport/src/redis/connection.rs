//! The connection to the server: commands and their answers, authentication, and riding out
//! an outage (back-off, reconnect, subscriptions renewed).

use std::io;
use std::time::{Duration, Instant};

use crate::error::{OpenError, SubscribeError};
use crate::validate_channel;

use super::RedisTransport;
use super::replies::{EarlyMessage, Reply, classify};
use super::resp::{self, RespError};

/// First and longest wait between reconnect attempts.
pub(super) const BACKOFF: (Duration, Duration) =
    (Duration::from_millis(50), Duration::from_millis(250));

/// Since when the server has been unreachable, and when to try again.
pub(super) struct Outage {
    pub(super) since: Instant,
    pub(super) next_attempt: Instant,
    pub(super) backoff: Duration,
}

/// Why a command on the subscriber's socket got no answer it could use. Its text becomes the
/// `reason` of the public error (with any password scrubbed).
#[derive(Debug, thiserror::Error)]
pub(super) enum CommandError {
    /// The server answered with an error reply (its text).
    #[error("{0}")]
    Refused(String),
    /// The socket failed.
    #[error("{0}")]
    Socket(#[from] io::Error),
    /// The server's bytes are not RESP.
    #[error("protocol error: {0}")]
    Protocol(&'static str),
    /// No answer in time.
    #[error("no answer within {0:?}")]
    NoAnswer(Duration),
    /// Connecting again failed.
    #[error("{0}")]
    Reconnect(#[from] OpenError),
}

impl CommandError {
    fn refused(text: &[u8]) -> Self {
        CommandError::Refused(String::from_utf8_lossy(text).into_owned())
    }
}

/// Whether a redis-rs error means the connection is gone (not a refusal by the server).
pub(super) fn connection_lost(e: &redis::RedisError) -> bool {
    e.is_io_error() || e.is_connection_dropped() || e.is_connection_refusal() || e.is_timeout()
}

impl RedisTransport {
    /// Authenticates the subscriber's socket, if the URL has a password (redis-rs has done the
    /// publishing connection).
    pub(super) fn authenticate(&mut self) -> Result<(), CommandError> {
        let Some(password) = self.endpoint.password.clone() else {
            return Ok(());
        };
        let mut auth = redis::cmd("AUTH");
        if let Some(user) = &self.endpoint.username {
            auth.arg(user);
        }
        auth.arg(&password);
        self.command(&auth.get_packed_command(), |reply| match reply {
            Reply::ServerError(text) => Some(Err(CommandError::refused(text))),
            Reply::Other => Some(Ok(())),
            _ => None,
        })
    }

    /// Notes that the server is unreachable (once per outage) and forgets what was half read.
    pub(super) fn went_down(&mut self) {
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
        tracing::warn!(
            server = %self.endpoint.addr,
            "Redis server unreachable: publishes are dropped (counted) while reconnecting"
        );
        self.current = None;
        self.early.clear();
        self.discard = 0;
    }

    /// Whether the server is reachable, reconnecting first if it is down and an attempt is due.
    pub(super) fn up(&mut self) -> bool {
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
                    let down = outage.since.elapsed();
                    self.intake.stats.down_ns += down.as_nanos() as u64;
                    tracing::info!(
                        server = %self.endpoint.addr,
                        down_ms = down.as_millis() as u64,
                        "Redis server reachable again; subscriptions renewed"
                    );
                }
                self.intake.stats.reconnects += 1;
                true
            }
            Err(reason) => {
                if let Some(outage) = &mut self.outage {
                    outage.backoff = (outage.backoff * 2).min(BACKOFF.1);
                    outage.next_attempt = Instant::now() + outage.backoff;
                    tracing::debug!(
                        server = %self.endpoint.addr,
                        retry_in_ms = outage.backoff.as_millis() as u64,
                        "reconnect failed: {}",
                        self.endpoint.scrub(reason.to_string())
                    );
                }
                false
            }
        }
    }

    /// Connects again, authenticates and renews every subscription.
    pub(super) fn reconnect(&mut self) -> Result<(), CommandError> {
        let (publisher, socket) = self
            .endpoint
            .connect(self.config.connect_timeout, self.config.timeout)?;
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
    pub(super) fn confirm(&mut self, command: &str, name: &str) -> Result<(), CommandError> {
        let packed = redis::cmd(command).arg(name).get_packed_command();
        let expected = command.to_ascii_lowercase();
        self.command(&packed, |reply| match reply {
            Reply::Confirmation { kind, channel }
                if *kind == expected.as_bytes() && *channel == name.as_bytes() =>
            {
                Some(Ok(()))
            }
            Reply::ServerError(text) => Some(Err(CommandError::refused(text))),
            _ => None,
        })
    }

    /// Sends a command on the subscribed socket and reads replies until `answer` recognises
    /// one; messages read meanwhile are kept for later receives.
    pub(super) fn command(
        &mut self,
        packed: &[u8],
        mut answer: impl FnMut(&Reply<'_>) -> Option<Result<(), CommandError>>,
    ) -> Result<(), CommandError> {
        self.current = None;
        self.socket.send(packed)?;
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
                            origin: crate::Envelope::default().origin(),
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
                Err(RespError::Protocol(what)) => return Err(CommandError::Protocol(what)),
            }
        }
    }

    pub(super) fn wait_for_bytes(
        &mut self,
        deadline: Instant,
        frame_limit: usize,
    ) -> Result<(), CommandError> {
        let now = Instant::now();
        if now >= deadline {
            return Err(CommandError::NoAnswer(self.config.timeout));
        }
        self.socket.fill(Some(deadline - now), frame_limit)?;
        Ok(())
    }

    pub(super) fn skip_discarded(&mut self) {
        let n = self.discard.min(self.socket.unparsed().len());
        self.socket.consume(n);
        self.discard -= n;
    }

    /// (Un)subscribes and keeps the list of subscriptions to renew after a reconnect. While
    /// the server is down the change is only recorded: the reconnect makes it.
    pub(super) fn subscription(
        &mut self,
        command: &'static str,
        name: &str,
    ) -> Result<(), SubscribeError> {
        validate_channel(name)?;
        let (kind, adds) = match command {
            "SUBSCRIBE" => ("SUBSCRIBE", true),
            "SSUBSCRIBE" => ("SSUBSCRIBE", true),
            "PSUBSCRIBE" => ("PSUBSCRIBE", true),
            "UNSUBSCRIBE" => ("SUBSCRIBE", false),
            "SUNSUBSCRIBE" => ("SSUBSCRIBE", false),
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
            Err(CommandError::Refused(reason)) if reason.starts_with("NOPERM") => {
                Err(SubscribeError::Refused {
                    addr: self.addr.clone(),
                    channel: name.to_owned(),
                    reason: self.endpoint.scrub(reason),
                })
            }
            Err(reason) => Err(SubscribeError::Disconnected {
                addr: self.addr.clone(),
                reason: self.endpoint.scrub(reason.to_string()),
            }),
        }
    }

    /// Whether the subscriber's socket is closed (checked after a failed command).
    pub(super) fn socket_lost(&mut self) -> bool {
        self.socket.fill(None, self.frame_limit()).is_err()
    }
}
