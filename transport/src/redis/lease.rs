//! Claims on Redis: a lease per name, `seam:claim:NAME`, whose value is the holder's token (this
//! transport's publisher id, then its description). Taken with `SET ... NX PX`, renewed by a
//! script that extends it only while the value is still this holder's, and given up when the
//! transport is dropped (a clean stop does not make the next holder wait). The server's
//! `TIME` when a lease is taken is the holder's incarnation: the next holder takes the name
//! only after this lease lapsed, so by the server's own clock its incarnation is larger, and
//! a server restarted with nothing kept still counts on from there.

use std::time::{Duration, Instant};

use redis::ConnectionLike;

use super::RedisTransport;
use super::connection::connection_lost;
use crate::error::ClaimError;

/// Renews the lease at `KEYS[1]` if it is still `ARGV[1]`'s (1), takes it again if it lapsed
/// and nobody took it (2), or returns who holds it now.
const RENEW: &str = "local v = redis.call('GET', KEYS[1]) \
    if v == ARGV[1] then redis.call('PEXPIRE', KEYS[1], ARGV[2]) return 1 end \
    if not v then redis.call('SET', KEYS[1], ARGV[1], 'PX', ARGV[2]) return 2 end \
    return v";

/// Takes the lease at `KEYS[1]` for `ARGV[1]` if nobody holds it (`SET ... NX PX ARGV[2]`)
/// and returns the server's time then, in microseconds (the incarnation); `false` if held.
const TAKE: &str = "if redis.call('SET', KEYS[1], ARGV[1], 'NX', 'PX', ARGV[2]) then \
    local t = redis.call('TIME') return tonumber(t[1]) * 1000000 + tonumber(t[2]) end \
    return false";

/// Deletes the lease at `KEYS[1]` if it is still `ARGV[1]`'s.
const RELEASE: &str = "if redis.call('GET', KEYS[1]) == ARGV[1] then \
    return redis.call('DEL', KEYS[1]) end return 0";

/// How often a refused claim asks again while it waits for a lease to lapse.
const POLL: Duration = Duration::from_millis(50);

/// A name this transport holds.
pub(crate) struct Lease {
    name: String,
    pub(super) key: String,
    token: String,
    renewed: Instant,
}

/// The Redis key of `name`'s lease.
pub(crate) fn key(name: &str) -> String {
    format!("seam:claim:{name}")
}

/// The holder's description in a lease value (after the publisher id).
fn holder_of(value: &str) -> String {
    value
        .split_once(' ')
        .map_or(value, |(_, holder)| holder)
        .to_owned()
}

impl RedisTransport {
    fn lease_ms(&self) -> u64 {
        self.config.lease.as_millis() as u64
    }

    /// `SET key token NX PX lease`: the server's time in microseconds if it was taken.
    fn try_take(&mut self, key: &str, token: &str) -> redis::RedisResult<Option<u64>> {
        redis::cmd("EVAL")
            .arg(TAKE)
            .arg(1)
            .arg(key)
            .arg(token)
            .arg(self.lease_ms())
            .query(&mut self.publisher)
    }

    /// The value and time to live (ms) of `key`, if it exists.
    fn lease_state(&mut self, key: &str) -> redis::RedisResult<Option<(String, i64)>> {
        let (value, ttl): (Option<String>, i64) = redis::pipe()
            .cmd("GET")
            .arg(key)
            .cmd("PTTL")
            .arg(key)
            .query(&mut self.publisher)?;
        Ok(value.map(|v| (v, ttl)))
    }

    /// See [`crate::Transport::claim`].
    pub(super) fn take_lease(&mut self, name: &str, holder: &str) -> Result<u64, ClaimError> {
        let unavailable = |e: redis::RedisError| ClaimError::Unavailable {
            name: name.to_owned(),
            reason: e.to_string(),
        };
        crate::validate_channel(name).map_err(|e| ClaimError::Unavailable {
            name: name.to_owned(),
            reason: e.to_string(),
        })?;
        let key = key(name);
        let token = format!("{:016x} {holder}", self.publisher_id);
        // A holder that stopped renewing (killed) lets its lease lapse within one lease; one
        // that renews is alive, and that is the answer.
        let deadline = Instant::now() + self.config.lease + POLL;
        let mut seen: Option<(String, i64)> = None;
        let incarnation = loop {
            if let Some(taken_us) = self.try_take(&key, &token).map_err(unavailable)? {
                break taken_us;
            }
            let now = self.lease_state(&key).map_err(unavailable)?;
            let renewed = match (&seen, &now) {
                (Some((before, ttl_before)), Some((value, ttl))) => {
                    value != before || ttl > ttl_before
                }
                _ => false,
            };
            if renewed || Instant::now() >= deadline {
                let holder = now
                    .or(seen)
                    .map_or_else(|| "another transport".to_owned(), |(v, _)| holder_of(&v));
                return Err(ClaimError::Held {
                    name: name.to_owned(),
                    holder,
                });
            }
            if now.is_some() {
                seen = now;
            }
            std::thread::sleep(POLL);
        };
        self.leases.push(Lease {
            name: name.to_owned(),
            key,
            token,
            renewed: Instant::now(),
        });
        Ok(incarnation)
    }

    /// See [`crate::Transport::keep_claims`].
    pub(super) fn keep_leases(&mut self) -> Result<(), ClaimError> {
        if self.outage.is_some() || self.leases.is_empty() {
            return Ok(());
        }
        let every = self.config.lease / 3;
        let lease_ms = self.lease_ms();
        for i in 0..self.leases.len() {
            if self.leases[i].renewed.elapsed() < every {
                continue;
            }
            let (key, token) = (self.leases[i].key.clone(), self.leases[i].token.clone());
            let answer: redis::RedisResult<redis::Value> = redis::cmd("EVAL")
                .arg(RENEW)
                .arg(1)
                .arg(&key)
                .arg(&token)
                .arg(lease_ms)
                .query(&mut self.publisher);
            match answer {
                Ok(redis::Value::Int(_)) => self.leases[i].renewed = Instant::now(),
                Ok(other) => {
                    let holder = redis::from_redis_value::<String>(other)
                        .map_or_else(|_| "another transport".to_owned(), |v| holder_of(&v));
                    return Err(ClaimError::Lost {
                        name: self.leases[i].name.clone(),
                        holder,
                    });
                }
                Err(e) if self.config.reconnect && connection_lost(&e) => {
                    self.went_down();
                    return Ok(());
                }
                // A Redis Cluster in the middle of a change: renewed once it settles (and on
                // the slot's new primary, where the cluster transport moves the lease).
                Err(e) if self.sharded && super::sharded::settling(&e) => return Ok(()),
                Err(e) => {
                    return Err(ClaimError::Unavailable {
                        name: self.leases[i].name.clone(),
                        reason: e.to_string(),
                    });
                }
            }
        }
        Ok(())
    }

    /// Whether it holds a lease.
    pub(crate) fn has_leases(&self) -> bool {
        !self.leases.is_empty()
    }

    /// The keys of the leases it holds (a Redis Cluster's transport moves them between
    /// nodes).
    pub(crate) fn lease_keys(&self) -> Vec<String> {
        self.leases.iter().map(|l| l.key.clone()).collect()
    }

    /// Takes out the lease at `key` (to be renewed on another node).
    pub(crate) fn remove_lease(&mut self, key: &str) -> Option<Lease> {
        let at = self.leases.iter().position(|l| l.key == key)?;
        Some(self.leases.swap_remove(at))
    }

    /// Holds `lease`, taken from another node's transport, from now on.
    pub(crate) fn give_lease(&mut self, lease: Lease) {
        self.leases.push(lease);
    }

    /// Gives up every lease still this transport's (when it is dropped).
    pub(super) fn release_leases(&mut self) {
        for lease in std::mem::take(&mut self.leases) {
            let packed = redis::cmd("EVAL")
                .arg(RELEASE)
                .arg(1)
                .arg(&lease.key)
                .arg(&lease.token)
                .get_packed_command();
            let _ = self.publisher.req_packed_command(&packed);
        }
    }
}
