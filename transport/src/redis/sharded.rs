//! Sharded pub/sub: one node of a Redis Cluster, as `crate::redis_cluster` drives it. The same
//! transport as for one server, with `SPUBLISH`, `SSUBSCRIBE` and `SUNSUBSCRIBE` in place of
//! the plain commands; a publish the node redirects and a subscription it drops unasked are
//! kept for the cluster transport to act on.

use std::os::fd::{AsFd, BorrowedFd};

use crate::envelope::Envelope;
use crate::error::{OpenError, PublishError, SubscribeError};
use crate::{Backend, Transport};

use super::RedisTransport;

/// The sharded form of a plain pub/sub command, when `sharded`.
pub(super) fn command(sharded: bool, plain: &'static str) -> &'static str {
    match (sharded, plain) {
        (true, "SUBSCRIBE") => "SSUBSCRIBE",
        (true, "UNSUBSCRIBE") => "SUNSUBSCRIBE",
        (_, plain) => plain,
    }
}

/// Whether `e` is a Redis Cluster's answer while it changes (a slot elsewhere now, moving,
/// or without a primary for the moment): what was asked is dropped or tried again later, not
/// an error.
pub(super) fn settling(e: &redis::RedisError) -> bool {
    use redis::{ErrorKind, ServerErrorKind as S};
    matches!(
        e.kind(),
        ErrorKind::Server(S::Moved | S::Ask | S::TryAgain | S::ClusterDown | S::MasterDown)
    )
}

/// The answer to a pattern subscription on sharded pub/sub, which has none: a channel lives
/// on the shard of its slot, a pattern would span them all.
pub(crate) fn no_patterns() -> SubscribeError {
    SubscribeError::Unsupported {
        backend: Backend::RedisCluster,
        what: "patterns",
        why: "sharded pub/sub (SSUBSCRIBE) delivers a channel only on the shard of its slot, \
              and has no pattern form; subscribe to each channel",
    }
}

impl RedisTransport {
    /// Connects to one node of a Redis Cluster for sharded pub/sub.
    pub(crate) fn open_sharded(url: &str) -> Result<Self, OpenError> {
        let mut transport = Self::open(url)?;
        transport.sharded = true;
        Ok(transport)
    }

    /// Publishes `payload` under an envelope made by the caller: a forwarded message's own, or
    /// one sealed by a Redis Cluster transport (which numbers the messages across nodes, so a
    /// channel that moves keeps its numbering).
    pub(crate) fn publish_enveloped(
        &mut self,
        channel: &str,
        envelope: Envelope,
        payload: &[u8],
    ) -> Result<usize, PublishError> {
        crate::channel::check_publish(channel, payload.len(), self.config.max_payload)?;
        if self.config.reconnect && !self.up() {
            self.intake.stats.dropped_while_down += 1;
            return Ok(0);
        }
        self.out.clear();
        self.out.resize(Envelope::WIRE_LEN, 0);
        self.out.extend_from_slice(payload);
        self.send(channel, envelope)
    }

    /// Where the node said the last publish's slot lives (`host:port`), once.
    pub(crate) fn take_redirect(&mut self) -> Option<String> {
        self.redirected.take()
    }

    /// Channels the node unsubscribed this transport from unasked (their slot moved, or the
    /// node is a primary no more), once; they are no longer renewed on reconnect.
    pub(crate) fn take_dropped_by_server(&mut self) -> Vec<String> {
        if self.dropped_by_server.is_empty() {
            return Vec::new();
        }
        let dropped = std::mem::take(&mut self.dropped_by_server);
        self.subscriptions
            .retain(|(_, name)| !dropped.iter().any(|d| d == name));
        dropped
    }

    /// Runs one command on the publishing connection (`CLUSTER SLOTS`, say).
    pub(crate) fn query(&mut self, cmd: &redis::Cmd) -> redis::RedisResult<redis::Value> {
        cmd.query(&mut self.publisher)
    }

    /// The subscriber's socket, to wait on beside other nodes' (`None` while disconnected).
    pub(crate) fn socket_fd(&self) -> Option<BorrowedFd<'_>> {
        self.outage.is_none().then(|| self.socket.as_fd())
    }

    /// Whether a receive would find something without reading the socket.
    pub(crate) fn has_buffered(&self) -> bool {
        !self.early.is_empty() || !self.socket.unparsed().is_empty()
    }

    /// Its settings.
    pub(crate) fn config(&self) -> &super::RedisConfig {
        &self.config
    }

    /// `host:port` of the node.
    pub(crate) fn addr(&self) -> &str {
        &self.addr
    }

    /// Whether it has no subscription left.
    pub(crate) fn has_subscriptions(&self) -> bool {
        !self.subscriptions.is_empty()
    }

    /// The transport's counters, as [`Transport::stats`] gives them.
    pub(crate) fn counters(&self) -> crate::Stats {
        Transport::stats(self)
    }
}
