//! seam-transport — publish-subscribe in Redis's vocabulary, on iceoryx2 shared memory for
//! cluster pods of one host, on iceoryx2 in-process for single-process runs, and on Redis (one
//! server, or a Redis Cluster) for pods on different hosts.
//!
//! Everything above this crate talks to [`Transport`] only, and picks a backend at run time with
//! a URL ([`open`]), so swapping shared memory for Redis changes no game code and the same op can
//! be timed with and without a network in between.
//!
//! | URL | backend |
//! |---|---|
//! | `shm`, `shm?prefix=test42&buffer=64` | [`ShmTransport`]: iceoryx2 `ipc::Service`, across processes |
//! | `local` | [`LocalTransport`]: iceoryx2 `local::Service`, one process |
//! | `redis://[user:password@]host:port[/db]` | [`RedisTransport`] |
//! | `rediss://[user:password@]host:port[/db][?tls_ca=PATH]` | [`RedisTransport`] over TLS |
//! | `redis-cluster://[user:password@]host:port[,host:port…]` | [`RedisClusterTransport`]: sharded pub/sub |
//! | `rediss-cluster://…[?tls_ca=PATH]` | [`RedisClusterTransport`] over TLS |
//!
//! Shared-memory settings are listed on [`IceoryxConfig`]; Redis settings on [`RedisConfig`]
//! (a Redis Cluster takes the same).
//!
//! # Layout
//!
//! - [`transport`](Transport) — the trait and [`Backend`].
//! - `channel` — the channel-name rule every backend enforces.
//! - `pattern` — Redis glob matching, for backends that match patterns themselves.
//! - `message` — [`Message`] (borrowed, zero copy) and [`OwnedMessage`].
//! - `envelope` — the header every message carries: publisher, sequence, length, tag, signer.
//! - `stats` — [`Stats`]: published, received, overflow and malformed drops.
//! - `error` — one error type per operation.
//! - `iceoryx` — the generic iceoryx2 backend behind `shm` and `local`.
//! - `redis` — the Redis backend.
//! - `redis_cluster` — the Redis Cluster backend: slot routing, one sharded Redis link per
//!   primary, following slot moves and failovers.
//! - [`auth`] — frame keys: the keyed tag a message carries when a deployment sets one.
//! - [`signing`] — per-cluster signatures: who signed a message, checked against a keyring.
//! - `url` — the one reader of a URL's `?key=value` settings.
//! - `fuzzing` — entry points for the fuzz targets in `fuzz/` (hidden; not part of the API).

pub mod auth;
mod channel;
mod envelope;
mod error;
mod iceoryx;
mod message;
mod pattern;
mod redis;
mod redis_cluster;
pub mod signing;
mod stats;
mod transport;
mod url;

pub use channel::{MAX_CHANNEL_LEN, validate_channel};
pub use envelope::{ENVELOPE_VERSION, Envelope};
pub use error::{ChannelError, ClaimError, OpenError, PublishError, ReceiveError, SubscribeError};
pub use iceoryx::{IceoryxConfig, IceoryxTransport, LocalTransport, ShmTransport};
pub use message::{Message, Origin, OwnedMessage};
pub use pattern::glob_match;
pub use redis::{RedisConfig, RedisTransport, redact_url};
pub use redis_cluster::{REFRESH_WHILE_DOWN, RedisClusterTransport};
pub use stats::Stats;
pub use transport::{Backend, Transport};

/// Entry points for the fuzz targets in `fuzz/`: not part of the API.
#[doc(hidden)]
pub mod fuzzing {
    /// Parses `bytes` as replies on a subscribed Redis connection and asserts what the reader
    /// promises of any input (see `fuzz/src/checks.rs`).
    pub fn resp_reader(bytes: &[u8]) {
        crate::redis::fuzz_check_resp(bytes);
    }
}

/// Opens the transport a URL names: `shm[?settings]`, `local[?settings]`, `redis://…`,
/// `rediss://…` (TLS), `redis-cluster://…` or `rediss-cluster://…` (TLS).
pub fn open(url: &str) -> Result<Box<dyn Transport>, OpenError> {
    let url = url.trim();
    if url.starts_with("redis-cluster://") || url.starts_with("rediss-cluster://") {
        return Ok(Box::new(RedisClusterTransport::open(url)?));
    }
    if ["redis://", "rediss://", "redis+unix://", "unix://"]
        .iter()
        .any(|scheme| url.starts_with(scheme))
    {
        return Ok(Box::new(RedisTransport::open(url)?));
    }
    let (scheme, settings) = crate::url::split(url);
    let backend = match scheme {
        "shm" => Backend::Shm,
        "local" => Backend::Local,
        _ => {
            return Err(OpenError::InvalidUrl {
                url: redact_url(url),
                reason: format!("unknown backend {scheme:?}"),
            });
        }
    };
    let mut config = IceoryxConfig::default();
    for setting in settings {
        config
            .set(setting.key, setting.value)
            .map_err(|reason| OpenError::InvalidUrl {
                url: redact_url(url),
                reason: reason.to_string(),
            })?;
    }
    Ok(match backend {
        Backend::Shm => Box::new(ShmTransport::open(backend, config)?),
        _ => Box::new(LocalTransport::open(backend, config)?),
    })
}
