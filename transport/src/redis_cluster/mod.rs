//! The Redis Cluster backend: `redis-cluster://[user:password@]HOST:PORT[,HOST:PORT…][?settings]`
//! (seed nodes; the settings are the Redis backend's).
//!
//! Sharded pub/sub: a channel is published with `SPUBLISH` to the primary serving its slot and
//! subscribed with `SSUBSCRIBE` there, one channel per command (a command naming channels of
//! several slots fails with `CROSSSLOT`). A channel's slot is the CRC16 of its name, or of its
//! hash tag: seam names a cluster's channels `replication:{ID}` and `physics_events:{ID}`, so
//! each cluster's two channels share a slot and clusters spread over the shards.
//!
//! One link per primary, each a [`RedisTransport`] in sharded mode (its own publishing
//! connection and subscribed socket, reconnects and counters), opened when a channel first
//! needs that primary. The slot map comes from `CLUSTER SLOTS` of the first seed that
//! answers; this transport follows it as it changes:
//!
//! - a publish the node answers `MOVED` or `ASK` is sent again where it says, and the slot
//!   noted (`Stats::redirects`);
//! - a node that stops serving a slot (the slot moved, or the node is a primary no more after a
//!   failover) unsubscribes its subscribers from the slot's channels unasked (`sunsubscribe`):
//!   the map is read again and each channel subscribed at the slot's new primary
//!   (`Stats::resubscribes`); what was published in between is lost, as in any outage;
//! - while a link is down (its primary killed), the map is read again every
//!   [`REFRESH_WHILE_DOWN`]; once a replica is promoted, the channels are subscribed there and
//!   publishes go there.
//!
//! Written here rather than with redis-rs's cluster client because redis-rs has sharded
//! pub/sub only in its async cluster connection (tokio, RESP3, messages through a
//! `push_sender` channel), and this transport is synchronous, reads its sockets without
//! blocking and waits on them itself (see `crate::redis`): the gap is that slot routing,
//! redirects and resubscription are this module's to get right (its tests and
//! `tests/tests/redis_cluster.rs` check them against a real cluster).

mod follow;
mod seeds;
mod slots;

use std::time::{Duration, Instant};

use rustix::event::{PollFd, PollFlags, Timespec};

use crate::channel::{check_publish, validate_channel};
use crate::envelope::{Envelope, Seal, SeqCounter, random_publisher_id};
use crate::error::{ClaimError, OpenError, PublishError, ReceiveError, SubscribeError};
use crate::redis::{RedisConfig, RedisTransport, claim_key, no_patterns};
use crate::{Backend, Message, Origin, Stats, Transport};
use slots::{SlotMap, slot_of};

/// How often the slot map is read again while a link is down.
pub const REFRESH_WHILE_DOWN: Duration = Duration::from_millis(50);

/// How long a claim is asked again while the cluster cannot answer it (its primary down until
/// a replica takes over).
const CLAIM_SETTLES_WITHIN: Duration = Duration::from_secs(6);

/// A transport over a Redis Cluster.
pub struct RedisClusterTransport {
    /// `redis://` and credentials, to which a node's `host:port` and the settings are added.
    scheme_and_user: String,
    /// The settings after `?` (with the `?`), or empty.
    query: String,
    seeds: Vec<String>,
    config: RedisConfig,
    /// The key and signer every published envelope is sealed with (from the first link's
    /// settings).
    seal: std::sync::Arc<Seal>,
    slots: SlotMap,
    links: Vec<RedisTransport>,
    publisher_id: u64,
    seqs: SeqCounter,
    out: Vec<u8>,
    /// Channels subscribed, with the link they are subscribed on.
    subscribed: Vec<(String, usize)>,
    /// The link the current message is in.
    current: Option<usize>,
    /// The link read first by the next receive (round robin).
    next: usize,
    /// Counts of links closed (their node gone).
    retired: Stats,
    resubscribes: u64,
    redirects: u64,
    /// Publishes dropped because the primary of their slot could not be reached.
    dropped_unreachable: u64,
    /// A primary the map names could not be reached: the map is read again (at most every
    /// [`REFRESH_WHILE_DOWN`]) until one that names reachable primaries comes.
    map_suspect: bool,
    last_refresh: Instant,
}

impl RedisClusterTransport {
    /// Connects to the first seed of `url` that answers and reads the slot map.
    pub fn open(url: &str) -> Result<Self, OpenError> {
        let (scheme_and_user, seeds, query) = seeds::parse(url)?;
        let mut transport = Self {
            scheme_and_user,
            query,
            seeds,
            config: RedisConfig::default(),
            seal: std::sync::Arc::default(),
            slots: SlotMap::default(),
            links: Vec::new(),
            publisher_id: random_publisher_id(),
            seqs: SeqCounter::default(),
            out: Vec::new(),
            subscribed: Vec::new(),
            current: None,
            next: 0,
            retired: Stats::default(),
            resubscribes: 0,
            redirects: 0,
            dropped_unreachable: 0,
            map_suspect: false,
            last_refresh: Instant::now(),
        };
        let mut failures = Vec::new();
        for seed in transport.seeds.clone() {
            match transport.read_slots_from(&seed) {
                Ok(()) => return Ok(transport),
                Err(
                    e @ (OpenError::InvalidUrl { .. } | OpenError::AuthenticationFailed { .. }),
                ) => {
                    return Err(e);
                }
                Err(e) => failures.push(e.to_string()),
            }
        }
        Err(OpenError::Unreachable {
            addr: transport.seeds.join(","),
            reason: format!(
                "no seed node gave a usable slot map: {}",
                failures.join("; ")
            ),
        })
    }

    fn node_url(&self, addr: &str) -> String {
        format!("{}{addr}{}", self.scheme_and_user, self.query)
    }

    /// Reads the slot map from `addr` (opening a link to it if it has none).
    fn read_slots_from(&mut self, addr: &str) -> Result<(), OpenError> {
        let index = self.link(addr)?;
        let link = &mut self.links[index];
        let reply = link
            .query(redis::cmd("CLUSTER").arg("SLOTS"))
            .map_err(|e| OpenError::Unreachable {
                addr: addr.to_owned(),
                reason: format!("CLUSTER SLOTS failed (is it a cluster node?): {e}"),
            })?;
        let host = addr.rsplit_once(':').map_or(addr, |(host, _)| host);
        self.slots = SlotMap::from_reply(&reply, host).map_err(|e| OpenError::Unreachable {
            addr: addr.to_owned(),
            reason: e.to_string(),
        })?;
        self.config = link.config().clone();
        self.seal = Seal::new(self.config.key.clone(), &self.config.signing);
        self.last_refresh = Instant::now();
        Ok(())
    }

    /// The link to `addr`, opened if there is none.
    fn link(&mut self, addr: &str) -> Result<usize, OpenError> {
        if let Some(index) = self.links.iter().position(|l| l.addr() == addr) {
            return Ok(index);
        }
        self.links
            .push(RedisTransport::open_sharded(&self.node_url(addr))?);
        Ok(self.links.len() - 1)
    }

    /// The link to the primary serving `channel`'s slot.
    fn link_for(&mut self, channel: &str) -> Result<usize, OpenError> {
        let primary = self.slots.primary_of(channel).to_owned();
        self.link(&primary)
    }
}

impl RedisClusterTransport {
    /// Publishes `self.out` under `envelope` at the primary of `channel`'s slot, following
    /// redirects; a primary that cannot be reached drops it, counted.
    fn send(&mut self, channel: &str, envelope: Envelope) -> Result<usize, PublishError> {
        self.follow();
        for _ in 0..3 {
            let Ok(link) = self.link_for(channel) else {
                self.dropped_unreachable += 1;
                self.map_suspect = true;
                return Ok(0);
            };
            let payload = std::mem::take(&mut self.out);
            let sent = self.links[link].publish_enveloped(channel, envelope, &payload);
            self.out = payload;
            let reached = sent?;
            match self.links[link].take_redirect() {
                None => return Ok(reached),
                Some(addr) => {
                    self.redirects += 1;
                    self.slots.moved(slot_of(channel), &addr);
                }
            }
        }
        self.dropped_unreachable += 1;
        Ok(0)
    }

    /// Reads the links with subscriptions once each, from the one after the last read;
    /// returns the link whose message is current, if one had one.
    fn receive_once(&mut self) -> Result<Option<usize>, ReceiveError> {
        self.follow();
        let n = self.links.len();
        for k in 0..n {
            let i = (self.next + k) % n;
            if !self.links[i].has_subscriptions() {
                continue;
            }
            if self.links[i].try_receive()?.is_some() {
                self.next = (i + 1) % n;
                return Ok(Some(i));
            }
        }
        Ok(None)
    }

    /// Waits up to `wait` for bytes on any subscribed link's socket.
    fn wait_for_any(&self, wait: Duration) {
        let listening = self.links.iter().filter(|l| l.has_subscriptions());
        if listening.clone().any(RedisTransport::has_buffered) {
            return;
        }
        let mut fds: Vec<PollFd<'_>> = listening
            .filter_map(RedisTransport::socket_fd)
            .map(|fd| PollFd::from_borrowed_fd(fd, PollFlags::IN))
            .collect();
        if fds.is_empty() {
            std::thread::sleep(wait);
            return;
        }
        let timeout = Timespec {
            tv_sec: wait.as_secs() as i64,
            tv_nsec: i64::from(wait.subsec_nanos()),
        };
        // An error (interrupted) only ends the wait early.
        let _ = rustix::event::poll(&mut fds, Some(&timeout));
    }
}

impl Transport for RedisClusterTransport {
    fn backend(&self) -> Backend {
        Backend::RedisCluster
    }

    fn publish_with(
        &mut self,
        channel: &str,
        capacity: usize,
        write: &mut dyn FnMut(&mut [u8]) -> Option<usize>,
    ) -> Result<usize, PublishError> {
        check_publish(channel, capacity, self.config.max_payload)?;
        self.out.clear();
        self.out.resize(capacity, 0);
        let written = write(&mut self.out).ok_or(PublishError::WriterAborted)?;
        if written > capacity {
            return Err(PublishError::WriterOverrun { written, capacity });
        }
        self.out.truncate(written);
        let seq = self.seqs.next(channel);
        let envelope = Envelope::sealed(&self.seal, channel, self.publisher_id, seq, &self.out);
        self.send(channel, envelope)
    }

    fn forward(
        &mut self,
        channel: &str,
        origin: Origin,
        payload: &[u8],
    ) -> Result<usize, PublishError> {
        check_publish(channel, payload.len(), self.config.max_payload)?;
        self.out.clear();
        self.out.extend_from_slice(payload);
        self.send(channel, Envelope::forwarded(origin, payload.len()))
    }

    fn claim(&mut self, name: &str, holder: &str) -> Result<u64, ClaimError> {
        // The key's primary may be down or moving (a pod restarted during a failover): asked
        // again, from a fresh slot map, for up to `CLAIM_SETTLES_WITHIN`.
        let deadline = Instant::now() + CLAIM_SETTLES_WITHIN;
        loop {
            let answer = match self.link_for(&claim_key(name)) {
                Ok(link) => self.links[link].claim(name, holder),
                Err(e) => Err(ClaimError::Unavailable {
                    name: name.to_owned(),
                    reason: e.to_string(),
                }),
            };
            match answer {
                Err(ClaimError::Unavailable { .. }) if Instant::now() < deadline => {
                    std::thread::sleep(REFRESH_WHILE_DOWN / 2);
                    self.follow_always();
                }
                answer => return answer,
            }
        }
    }

    fn keep_claims(&mut self) -> Result<(), ClaimError> {
        self.follow();
        self.move_leases();
        self.links
            .iter_mut()
            .try_for_each(|link| link.keep_claims())
    }

    fn subscribe(&mut self, channel: &str) -> Result<(), SubscribeError> {
        validate_channel(channel)?;
        if self.subscribed.iter().any(|(c, _)| c == channel) {
            return Ok(());
        }
        self.follow();
        let link = self.link_for(channel);
        self.map_suspect |= link.is_err();
        let link = link.map_err(|e| SubscribeError::Disconnected {
            addr: self.slots.primary_of(channel).to_owned(),
            reason: e.to_string(),
        })?;
        self.links[link].subscribe(channel)?;
        self.subscribed.push((channel.to_owned(), link));
        Ok(())
    }

    fn unsubscribe(&mut self, channel: &str) -> Result<(), SubscribeError> {
        validate_channel(channel)?;
        if let Some(at) = self.subscribed.iter().position(|(c, _)| c == channel) {
            let (_, link) = self.subscribed.swap_remove(at);
            self.links[link].unsubscribe(channel)?;
        }
        Ok(())
    }

    fn psubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError> {
        validate_channel(pattern)?;
        Err(no_patterns())
    }

    fn punsubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError> {
        validate_channel(pattern)?;
        Err(no_patterns())
    }

    fn try_receive(&mut self) -> Result<Option<Message<'_>>, ReceiveError> {
        self.current = self.receive_once()?;
        Ok(self.current.and_then(|i| self.links[i].current_message()))
    }

    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<Message<'_>>, ReceiveError> {
        let deadline = Instant::now() + timeout;
        loop {
            self.current = self.receive_once()?;
            if let Some(i) = self.current {
                return Ok(self.links[i].current_message());
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            let mut wait = deadline - now;
            if self.links.iter().any(|l| !l.is_connected()) {
                wait = wait.min(REFRESH_WHILE_DOWN / 4);
            }
            self.wait_for_any(wait);
        }
    }

    fn stats(&self) -> Stats {
        let mut total = self.retired;
        for link in &self.links {
            total.add(&link.counters());
        }
        total.dropped_while_down += self.dropped_unreachable;
        total.resubscribes += self.resubscribes;
        total.redirects += self.redirects;
        total
    }

    fn is_connected(&self) -> bool {
        self.subscribed
            .iter()
            .all(|&(_, link)| self.links[link].is_connected())
    }

    fn max_payload(&self) -> usize {
        self.config.max_payload
    }
}
