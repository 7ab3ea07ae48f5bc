//! The trait every backend implements.

use std::time::Duration;

use crate::error::{ClaimError, PublishError, ReceiveError, SubscribeError};
use crate::{Message, OwnedMessage, Stats};

/// Which backend a transport runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Backend {
    /// iceoryx2 shared memory between processes of one host.
    Shm,
    /// iceoryx2 within one process.
    Local,
    /// A Redis server.
    Redis,
    /// A Redis Cluster, with sharded pub/sub.
    RedisCluster,
}

impl Backend {
    /// The URL scheme that selects this backend: `shm`, `local`, `redis` or
    /// `redis-cluster`.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Shm => "shm",
            Backend::Local => "local",
            Backend::Redis => "redis",
            Backend::RedisCluster => "redis-cluster",
        }
    }
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Publish-subscribe in Redis's vocabulary.
///
/// Delivery is best-effort and at-most-once, first-in first-out per publisher and channel, as in
/// Redis. A receiver that falls behind loses the oldest messages (on shared memory when its buffer
/// of `buffer` messages is full; on Redis when the server's output-buffer limit cuts it off); the
/// loss is counted in [`Stats::overflow_drops`], and a publisher never blocks on it.
///
/// On the iceoryx2 backends, messages a receiver has not taken yet are lost when their publisher
/// closes (iceoryx2 unmaps a closed publisher's samples); Redis keeps them. A pod that must get
/// its last frame out keeps its transport open until peers have read it.
///
/// A transport is used from one thread (iceoryx2 ports are not `Send`); every pod or cluster owns
/// its own.
pub trait Transport {
    /// The backend behind this transport.
    fn backend(&self) -> Backend;

    /// Publishes `payload` on `channel`; returns how many subscribers it reached.
    fn publish(&mut self, channel: &str, payload: &[u8]) -> Result<usize, PublishError> {
        self.publish_with(channel, payload.len(), &mut |buffer| {
            buffer[..payload.len()].copy_from_slice(payload);
            Some(payload.len())
        })
    }

    /// Publishes a payload written in place: `write` gets a zeroed buffer of `capacity` bytes
    /// (on shared memory, the loaned sample itself), writes the payload at its start and returns
    /// the length written, or `None` to publish nothing. Returns how many subscribers it reached.
    fn publish_with(
        &mut self,
        channel: &str,
        capacity: usize,
        write: &mut dyn FnMut(&mut [u8]) -> Option<usize>,
    ) -> Result<usize, PublishError>;

    /// Publishes a message received from another transport under its own envelope (`origin`:
    /// its publisher and number), for a bridge between backends: receivers count gaps and tell
    /// publishers apart as if it had come straight from its publisher. The transport's own
    /// numbering on `channel` is not advanced. Returns how many subscribers it reached.
    fn forward(
        &mut self,
        channel: &str,
        origin: crate::Origin,
        payload: &[u8],
    ) -> Result<usize, PublishError>;

    /// Forwards several received messages in order, as [`Transport::forward`] each; returns
    /// how many were sent. On Redis they go out as one pipeline — one round trip to the server
    /// for the batch instead of one per message — which is what keeps a bridge in step with
    /// its host when the server is far away.
    fn forward_all(&mut self, batch: &[OwnedMessage]) -> Result<usize, PublishError> {
        for message in batch {
            self.forward(&message.channel, message.origin, &message.payload)?;
        }
        Ok(batch.len())
    }

    /// Gets ready to publish on `channel` payloads of about `expected_payload` bytes, so the
    /// first publish costs no more than the next ones. On iceoryx2 this creates the channel's
    /// service and publisher now, with shared memory for `expected_payload` (capped at the
    /// maximum payload), instead of at the first publish; Redis has nothing to prepare.
    /// Publishing works without it.
    fn advertise(&mut self, channel: &str, expected_payload: usize) -> Result<(), PublishError> {
        let _ = expected_payload;
        crate::channel::validate_channel(channel)?;
        Ok(())
    }

    /// Takes `name` for as long as this transport lives: one transport at a time holds a name
    /// among all of a backend's (one shared-memory prefix, one Redis server), which is how a
    /// cluster makes sure it runs once. `holder` says who takes it (a process and host); a
    /// transport refused gets it in [`ClaimError::Held`].
    ///
    /// On iceoryx2 the claim is a service that admits one publisher, held by this transport's
    /// node (a killed holder's is reclaimed by iceoryx2's dead-node cleanup). On Redis it is a
    /// lease, `SET seam:claim:NAME ... NX PX lease_ms` (3 s unless the URL's `lease_ms` says
    /// otherwise), renewed by [`Transport::keep_claims`]: a new holder takes a name over only
    /// once the old lease lapsed, so this waits up to one lease for a holder that stopped
    /// renewing (killed) and answers `Held` as soon as it sees the lease renewed.
    ///
    /// Returns the claim's incarnation: the time it was taken, in microseconds since the UNIX
    /// epoch, by the backend's one clock (this host's on iceoryx2, the Redis server's `TIME`
    /// on Redis, read in the same script that takes the lease). Holders of a name follow one
    /// another, so each later holder's incarnation is larger (unless that clock is stepped
    /// back by more than the time between them): a receiver that keeps the largest it has
    /// seen tells a stale holder's messages from its successor's (a fencing token).
    fn claim(&mut self, name: &str, holder: &str) -> Result<u64, ClaimError>;

    /// Keeps this transport's claims alive; call it often (every tick). On Redis it renews each
    /// lease once a third of it has passed, and takes a lapsed one back if nobody else took it;
    /// [`ClaimError::Lost`] when another transport holds it now. While the server is down it
    /// does nothing (the outage is counted as usual).
    fn keep_claims(&mut self) -> Result<(), ClaimError> {
        Ok(())
    }

    /// Starts receiving messages published on `channel`.
    fn subscribe(&mut self, channel: &str) -> Result<(), SubscribeError>;

    /// Stops receiving messages of `channel` (subscribing by name only; patterns stay).
    fn unsubscribe(&mut self, channel: &str) -> Result<(), SubscribeError>;

    /// Starts receiving messages of every channel that matches the glob `pattern`
    /// (`*`, `?`, `[...]`, `\`), as Redis `PSUBSCRIBE`.
    fn psubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError>;

    /// Stops receiving through `pattern`.
    fn punsubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError>;

    /// Returns the next message if one is already here, without blocking.
    fn try_receive(&mut self) -> Result<Option<Message<'_>>, ReceiveError>;

    /// Returns the next message, sleeping (not spinning) up to `timeout` for one to arrive.
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<Message<'_>>, ReceiveError>;

    /// What the transport has counted since it was opened.
    fn stats(&self) -> Stats;

    /// Largest payload a publish accepts, in bytes.
    fn max_payload(&self) -> usize;

    /// Whether the transport reaches its peers now. A backend that loses its server and
    /// reconnects on its own (Redis) says `false` while it is down; shared memory is always
    /// connected.
    fn is_connected(&self) -> bool {
        true
    }
}
