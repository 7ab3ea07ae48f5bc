//! The Redis backend: `redis://[user:password@]host:port[/db][?max_payload=N&timeout_ms=N&connect_ms=N&reconnect=0|1&lease_ms=N]`,
//! or `rediss://…[?tls_ca=PATH]` for TLS (the server's certificate verified against the PEM
//! file's CAs, or the system's roots).
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
//!
//! Files: `config` (the URL, settings and server it names, passwords redacted), `connection`
//! (commands and their answers, authentication, outages and reconnects), `lease` (claims:
//! one holder per name, see `Transport::claim`), `replies` (what the
//! subscribed socket brings, parsed in place), `resp` (the RESP parser), `socket` (the
//! subscriber's non-blocking socket), `tls` (the roots and sessions of `rediss://`).

mod config;
mod connection;
mod lease;
mod replies;
mod resp;
mod sharded;

pub(crate) use resp::fuzz_check as fuzz_check_resp;
mod socket;
mod tls;

use config::Endpoint;
pub use config::{RedisConfig, redact_url};
use connection::{Outage, connection_lost};
pub(crate) use lease::key as claim_key;
use replies::{Current, EarlyMessage};
pub(crate) use sharded::no_patterns;

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use redis::ConnectionLike;

use crate::channel::check_publish;
use crate::envelope::{Envelope, Intake, Seal, SeqCounter, random_publisher_id};
use crate::error::{ClaimError, OpenError, PublishError, ReceiveError, SubscribeError};
use crate::{Backend, MAX_CHANNEL_LEN, Message, Stats, Transport};
use socket::Socket;

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
    /// The key and signer every published envelope is sealed with.
    seal: std::sync::Arc<Seal>,
    /// Subscriptions in force, to renew after a reconnect: (`SUBSCRIBE` or `PSUBSCRIBE`, name).
    subscriptions: Vec<(&'static str, String)>,
    /// Set while the server is unreachable.
    outage: Option<Outage>,
    /// Names this transport holds (see [`Transport::claim`]).
    leases: Vec<lease::Lease>,
    /// Sharded pub/sub (`SPUBLISH`, `SSUBSCRIBE`): one node of a Redis Cluster, driven by
    /// `crate::redis_cluster`.
    sharded: bool,
    /// Where the server said the last publish's slot lives (`MOVED`/`ASK`), not yet taken.
    redirected: Option<String>,
    /// Sharded channels the server unsubscribed this transport from unasked (their slot is no
    /// longer served here), not yet taken.
    dropped_by_server: Vec<String>,
}

impl Drop for RedisTransport {
    fn drop(&mut self) {
        self.release_leases();
    }
}

impl RedisTransport {
    /// Connects to the Redis server named by `url`.
    pub fn open(url: &str) -> Result<Self, OpenError> {
        let (config, endpoint) = Endpoint::from_url(url)?;
        let intake = Intake::new(config.key.clone(), config.signing.keyring.clone());
        let seal = Seal::new(config.key.clone(), &config.signing);
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
            intake,
            seal,
            subscriptions: Vec::new(),
            outage: None,
            leases: Vec::new(),
            sharded: false,
            redirected: None,
            dropped_by_server: Vec::new(),
        };
        transport
            .authenticate()
            .map_err(|reason| OpenError::AuthenticationFailed {
                addr: transport.addr.clone(),
                reason: transport.endpoint.scrub(reason.to_string()),
            })?;
        Ok(transport)
    }

    /// Largest reply the subscriber accepts: a message of `max_payload` and its framing.
    fn frame_limit(&self) -> usize {
        self.max_bulk() + 2 * MAX_CHANNEL_LEN + 128
    }

    fn max_bulk(&self) -> usize {
        self.config.max_payload + Envelope::WIRE_LEN
    }

    /// Writes `envelope` in front of the payload in `self.out` and publishes it.
    fn send(&mut self, channel: &str, envelope: Envelope) -> Result<usize, PublishError> {
        let head: &mut [u8; Envelope::WIRE_LEN] = (&mut self.out[..Envelope::WIRE_LEN])
            .try_into()
            .expect("the buffer starts with room for the envelope");
        envelope.write_to(head);
        let packed = redis::cmd(if self.sharded { "SPUBLISH" } else { "PUBLISH" })
            .arg(channel)
            .arg(&self.out[..])
            .get_packed_command();
        let reached = match self
            .publisher
            .req_packed_command(&packed)
            .and_then(redis::Value::extract_error)
            .and_then(|value| redis::from_redis_value::<usize>(value).map_err(Into::into))
        {
            Ok(reached) => reached,
            Err(e) if self.config.reconnect && connection_lost(&e) => {
                self.went_down();
                self.intake.stats.dropped_while_down += 1;
                return Ok(0);
            }
            Err(e) if self.sharded && e.redirect_node().is_some() => {
                self.redirected = e.redirect_node().map(|(addr, _)| addr.to_owned());
                return Ok(0);
            }
            Err(e) if self.sharded && sharded::settling(&e) => {
                self.intake.stats.dropped_while_down += 1;
                return Ok(0);
            }
            Err(e) if e.code() == Some("NOPERM") => {
                return Err(PublishError::Refused {
                    addr: self.addr.clone(),
                    channel: channel.to_owned(),
                    reason: self.endpoint.scrub(e.to_string()),
                });
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
        check_publish(channel, capacity, self.config.max_payload)?;
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
        let envelope = Envelope::sealed(
            &self.seal,
            channel,
            self.publisher_id,
            seq,
            &self.out[Envelope::WIRE_LEN..],
        );
        self.send(channel, envelope)
    }

    fn forward(
        &mut self,
        channel: &str,
        origin: crate::Origin,
        payload: &[u8],
    ) -> Result<usize, PublishError> {
        self.publish_enveloped(channel, Envelope::forwarded(origin, payload.len()), payload)
    }

    fn forward_all(&mut self, batch: &[crate::OwnedMessage]) -> Result<usize, PublishError> {
        for message in batch {
            check_publish(
                &message.channel,
                message.payload.len(),
                self.config.max_payload,
            )?;
        }
        if batch.is_empty() {
            return Ok(0);
        }
        if self.config.reconnect && !self.up() {
            self.intake.stats.dropped_while_down += batch.len() as u64;
            return Ok(0);
        }
        let mut pipeline = redis::pipe();
        for message in batch {
            self.out.clear();
            self.out.resize(Envelope::WIRE_LEN, 0);
            let head: &mut [u8; Envelope::WIRE_LEN] = (&mut self.out[..Envelope::WIRE_LEN])
                .try_into()
                .expect("the buffer starts with room for the envelope");
            Envelope::forwarded(message.origin, message.payload.len()).write_to(head);
            self.out.extend_from_slice(&message.payload);
            pipeline
                .cmd("PUBLISH")
                .arg(&message.channel)
                .arg(&self.out[..])
                .ignore();
        }
        match pipeline.exec(&mut self.publisher) {
            Ok(()) => {
                self.intake.stats.published += batch.len() as u64;
                Ok(batch.len())
            }
            Err(e) if self.config.reconnect && connection_lost(&e) => {
                self.went_down();
                self.intake.stats.dropped_while_down += batch.len() as u64;
                Ok(0)
            }
            Err(e) => Err(PublishError::Disconnected {
                addr: self.addr.clone(),
                reason: e.to_string(),
            }),
        }
    }

    fn claim(&mut self, name: &str, holder: &str) -> Result<u64, ClaimError> {
        self.take_lease(name, holder)
    }

    fn keep_claims(&mut self) -> Result<(), ClaimError> {
        self.keep_leases()
    }

    fn subscribe(&mut self, channel: &str) -> Result<(), SubscribeError> {
        self.subscription(sharded::command(self.sharded, "SUBSCRIBE"), channel)
    }

    fn unsubscribe(&mut self, channel: &str) -> Result<(), SubscribeError> {
        self.subscription(sharded::command(self.sharded, "UNSUBSCRIBE"), channel)?;
        let key = self.intake.channel_key(channel);
        self.intake.forget_channel(key);
        Ok(())
    }

    fn psubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError> {
        if self.sharded {
            return Err(sharded::no_patterns());
        }
        self.subscription("PSUBSCRIBE", pattern)
    }

    fn punsubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError> {
        if self.sharded {
            return Err(sharded::no_patterns());
        }
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
