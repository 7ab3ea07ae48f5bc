//! One error type per operation, each saying what was wrong and what to do about it.

use thiserror::Error;

/// A channel name or pattern that breaks the common rule (see [`crate::validate_channel`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum ChannelError {
    /// The name is empty.
    #[error("channel name is empty: give it at least one printable ASCII character")]
    Empty,
    /// The name is longer than iceoryx2 allows for a service name.
    #[error(
        "channel name is {len} bytes long; the limit is {max} bytes (iceoryx2's service-name limit)"
    )]
    TooLong {
        /// Length of the rejected name.
        len: usize,
        /// The limit.
        max: usize,
    },
    /// The name holds a byte that is not printable ASCII (space, control, non-ASCII).
    #[error(
        "channel name has a byte at position {position} that is not printable ASCII ('!'..='~')"
    )]
    NotPrintableAscii {
        /// Byte offset of the first offending byte.
        position: usize,
    },
    /// The name starts with `iox2://`, which iceoryx2 keeps for itself.
    #[error("channel names starting with \"iox2://\" are reserved by iceoryx2")]
    Reserved,
}

/// Why a transport could not be opened.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum OpenError {
    /// The transport URL is not one seam understands.
    #[error(
        "invalid transport URL {url:?}: {reason}. Use `shm`, `shm?prefix=NAME`, `local` or `redis://HOST:PORT`"
    )]
    InvalidUrl {
        /// The URL, with any password replaced by `***`.
        url: String,
        /// What was wrong with it.
        reason: String,
    },
    /// No server answered at the address.
    #[error(
        "cannot reach the Redis server at {addr}: {reason}. Is it running? (`redis-server --port PORT`)"
    )]
    Unreachable {
        /// `host:port` or socket path; never the password.
        addr: String,
        /// What the connection attempt reported.
        reason: String,
    },
    /// The server answered but refused the credentials.
    #[error(
        "the Redis server at {addr} refused authentication: {reason}. Check user and password in the URL"
    )]
    AuthenticationFailed {
        /// `host:port` or socket path.
        addr: String,
        /// The server's answer.
        reason: String,
    },
    /// iceoryx2 could not create the node (root directory, permissions, shared memory).
    #[error(
        "cannot start iceoryx2 ({what}): {reason}. Check that /dev/shm is writable and the iceoryx2 root directory belongs to this user"
    )]
    SharedMemory {
        /// Which step failed.
        what: &'static str,
        /// iceoryx2's error.
        reason: String,
    },
}

/// Why a publish did not happen.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum PublishError {
    /// The channel name breaks the common rule.
    #[error(transparent)]
    Channel(#[from] ChannelError),
    /// The payload is larger than this transport's `max_payload`.
    #[error(
        "payload of {len} bytes exceeds the configured maximum of {max} bytes; raise `max_payload` in the transport URL or split the frame"
    )]
    PayloadTooLarge {
        /// Payload length.
        len: usize,
        /// Configured maximum.
        max: usize,
    },
    /// The writer given to [`crate::Transport::publish_with`] gave up; nothing was sent.
    #[error("the payload writer aborted; nothing was published")]
    WriterAborted,
    /// The writer claimed to have written more than the buffer it was given.
    #[error("the payload writer reported {written} bytes written into a buffer of {capacity}")]
    WriterOverrun {
        /// Bytes the writer reported.
        written: usize,
        /// Buffer size it was given.
        capacity: usize,
    },
    /// The shared-memory service exists with settings this transport cannot use.
    #[error(
        "channel {channel:?} exists with incompatible settings ({reason}); every pod on a host must use the same shm settings"
    )]
    IncompatibleService {
        /// The channel.
        channel: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// The shared-memory service refused a new port (limits reached, resources exhausted).
    #[error("cannot publish on channel {channel:?}: {reason}")]
    PortUnavailable {
        /// The channel.
        channel: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// The Redis connection failed.
    #[error("lost the Redis server at {addr}: {reason}")]
    Disconnected {
        /// `host:port` or socket path.
        addr: String,
        /// What failed.
        reason: String,
    },
    /// The server refused the publish (`NOPERM`: this login's ACL user may not publish on
    /// the channel).
    #[error(
        "the Redis server at {addr} refused publishing on {channel:?} to this login (its ACL user may not publish there): {reason}"
    )]
    Refused {
        /// `host:port` or socket path.
        addr: String,
        /// The channel.
        channel: String,
        /// The server's answer.
        reason: String,
    },
}

/// Why a subscription change did not happen.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum SubscribeError {
    /// The channel name or pattern breaks the common rule.
    #[error(transparent)]
    Channel(#[from] ChannelError),
    /// The shared-memory service exists with settings this transport cannot use.
    #[error(
        "channel {channel:?} exists with incompatible settings ({reason}); every pod on a host must use the same shm settings"
    )]
    IncompatibleService {
        /// The channel.
        channel: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// The shared-memory service refused a new port (limits reached, resources exhausted).
    #[error("cannot subscribe to channel {channel:?}: {reason}")]
    PortUnavailable {
        /// The channel.
        channel: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// The Redis connection failed or the server did not confirm in time.
    #[error("lost the Redis server at {addr}: {reason}")]
    Disconnected {
        /// `host:port` or socket path.
        addr: String,
        /// What failed.
        reason: String,
    },
    /// The server refused the subscription (`NOPERM`: this login's ACL user may not read the
    /// channel).
    #[error(
        "the Redis server at {addr} refused subscribing to {channel:?} to this login (its ACL user may not read it): {reason}"
    )]
    Refused {
        /// `host:port` or socket path.
        addr: String,
        /// The channel or pattern.
        channel: String,
        /// The server's answer.
        reason: String,
    },
    /// The backend has no such subscription.
    #[error("{backend} cannot subscribe to {what}: {why}")]
    Unsupported {
        /// The backend.
        backend: crate::Backend,
        /// What was asked (`patterns`).
        what: &'static str,
        /// Why not.
        why: &'static str,
    },
}

/// Why a receive failed. Malformed messages and overflows are not errors: they are counted in
/// [`crate::Stats`] and skipped.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum ReceiveError {
    /// The Redis connection failed.
    #[error("lost the Redis server at {addr}: {reason}")]
    Disconnected {
        /// `host:port` or socket path.
        addr: String,
        /// What failed.
        reason: String,
    },
    /// The shared-memory connection to a publisher is broken.
    #[error("shared-memory receive on channel {channel:?} failed: {reason}")]
    SharedMemory {
        /// The channel.
        channel: String,
        /// iceoryx2's reason.
        reason: String,
    },
}

/// Why a claim (see [`Transport::claim`](crate::Transport::claim)) failed or ended.
#[derive(Debug, thiserror::Error)]
pub enum ClaimError {
    /// Another live transport holds the name.
    #[error("{name:?} is held by {holder}")]
    Held {
        /// The name.
        name: String,
        /// Who holds it, as it described itself when it took the name.
        holder: String,
    },
    /// This transport held the name, let its lease lapse (stopped, or cut off from the server
    /// for longer than the lease), and another took it over.
    #[error("{name:?} was taken over by {holder} after this holder's lease lapsed")]
    Lost {
        /// The name.
        name: String,
        /// Who holds it now.
        holder: String,
    },
    /// The backend could not be asked.
    #[error("cannot claim {name:?}: {reason}")]
    Unavailable {
        /// The name.
        name: String,
        /// What failed.
        reason: String,
    },
}
