//! The iceoryx2 backends: `shm` (`ipc::Service`, across processes) and `local`
//! (`local::Service`, one process). One generic implementation serves both.
//!
//! Each channel is an iceoryx2 publish-subscribe service of `[u8]` with the seam [`Envelope`] as
//! user header, paired with an event service of the same name. A publisher writes straight into
//! its loaned sample, sends it and notifies the event service; iceoryx2 sends a wake-up datagram
//! only when a listener has consumed the previous one, so publishing to a busy-polling receiver
//! costs an atomic, not a syscall. A receiver polls its subscribers round-robin and, when told to
//! wait, sleeps on its listeners in a WaitSet.
//!
//! Pattern subscriptions are emulated: the backend lists the services under its prefix (at
//! `psubscribe` and every `discovery_interval` while receiving) and subscribes to each new match.
//! A channel therefore reaches a pattern subscriber only after discovery has seen it, and
//! `publish` counts a pattern subscriber once it has subscribed. A channel matched both directly
//! and by patterns is received once (Redis would deliver it once per subscription).

mod claim;
mod config;
mod ports;
mod receive;

pub use config::IceoryxConfig;

use std::collections::{HashMap, HashSet};
use std::time::{Duration, Instant};

use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::*;
use iceoryx2::service::Service;

use crate::channel::check_publish;
use crate::envelope::{Intake, Seal, random_publisher_id};
use crate::error::{ClaimError, OpenError, PublishError, ReceiveError, SubscribeError};
use crate::{Backend, Message, Stats, Transport, validate_channel};
use ports::{Inlet, Outlet, PortError};

/// A transport over iceoryx2 services of type `S`.
pub struct IceoryxTransport<S: Service> {
    node: Node<S>,
    config: IceoryxConfig,
    backend: Backend,
    publisher_id: u64,
    outlets: HashMap<String, Outlet<S>>,
    inlets: Vec<Inlet<S>>,
    patterns: Vec<String>,
    /// Channels a pattern matched but whose service seam cannot use (a foreign payload type).
    unusable: HashSet<String>,
    next_discovery: Instant,
    cursor: usize,
    /// The sample behind the last returned message: (index into `inlets`, sample).
    current: Option<(usize, ports::InSample<S>)>,
    intake: Intake,
    /// The key and signer every published envelope is sealed with.
    seal: std::sync::Arc<Seal>,
    /// Names this transport holds (see [`Transport::claim`]).
    claims: Vec<claim::Claim<S>>,
}

/// Shared memory across the processes of one host.
pub type ShmTransport = IceoryxTransport<ipc::Service>;
/// iceoryx2 within one process.
pub type LocalTransport = IceoryxTransport<local::Service>;

// `Listener<S>: SynchronousMultiplexing` lets a WaitSet sleep on the listeners; `ipc::Service`
// and `local::Service` both meet it.
impl<S: Service> IceoryxTransport<S>
where
    Listener<S>: SynchronousMultiplexing,
{
    /// Starts an iceoryx2 node with `config` and reclaims what dead nodes left behind.
    pub fn open(backend: Backend, config: IceoryxConfig) -> Result<Self, OpenError> {
        // iceoryx2 logs every failure it returns; seam reports them as typed errors instead.
        // IOX2_LOG_LEVEL still turns its log back on for debugging.
        set_log_level_from_env_or(LogLevel::Fatal);
        let mut iox_config = iceoryx2::config::Config::default();
        iox_config.global.prefix =
            FileName::new(config.prefix.as_bytes()).map_err(|e| OpenError::SharedMemory {
                what: "prefix",
                reason: format!("{e:?}"),
            })?;
        let node = NodeBuilder::new()
            .config(&iox_config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<S>()
            .map_err(|e| OpenError::SharedMemory {
                what: "node",
                reason: e.to_string(),
            })?;
        // Pods that crashed leave shared memory and service registrations behind.
        node.try_cleanup_dead_nodes();
        Ok(Self {
            node,
            backend,
            publisher_id: random_publisher_id(),
            outlets: HashMap::new(),
            inlets: Vec::new(),
            patterns: Vec::new(),
            unusable: HashSet::new(),
            next_discovery: Instant::now(),
            cursor: 0,
            current: None,
            intake: Intake::new(config.key.clone(), config.signing.keyring.clone()),
            seal: Seal::new(config.key.clone(), &config.signing),
            claims: Vec::new(),
            config,
        })
    }

    /// The settings this transport was opened with.
    pub fn config(&self) -> &IceoryxConfig {
        &self.config
    }

    /// The channel's outlet, created (with room for `initial_len` bytes) if it has none yet.
    fn outlet(
        &mut self,
        channel: &str,
        initial_len: usize,
    ) -> Result<&mut Outlet<S>, PublishError> {
        if !self.outlets.contains_key(channel) {
            let outlet = Outlet::create(&self.node, &self.config, channel, initial_len).map_err(
                |e| match e {
                    PortError::Incompatible(reason) => PublishError::IncompatibleService {
                        channel: channel.to_owned(),
                        reason,
                    },
                    PortError::Unavailable(reason) => PublishError::PortUnavailable {
                        channel: channel.to_owned(),
                        reason,
                    },
                },
            )?;
            self.outlets.insert(channel.to_owned(), outlet);
        }
        Ok(self
            .outlets
            .get_mut(channel)
            .expect("the outlet was inserted above"))
    }

    fn inlet_index(&self, channel: &str) -> Option<usize> {
        self.inlets
            .iter()
            .position(|inlet| inlet.channel == channel)
    }

    fn add_inlet(&mut self, channel: &str, pattern: Option<&str>) -> Result<(), SubscribeError> {
        let key = self.intake.channel_key(channel);
        let inlet = Inlet::create(&self.node, &self.config, channel, pattern, key).map_err(
            |e| match e {
                PortError::Incompatible(reason) => SubscribeError::IncompatibleService {
                    channel: channel.to_owned(),
                    reason,
                },
                PortError::Unavailable(reason) => SubscribeError::PortUnavailable {
                    channel: channel.to_owned(),
                    reason,
                },
            },
        )?;
        self.inlets.push(inlet);
        Ok(())
    }

    fn remove_inlet(&mut self, index: usize) {
        self.current = None;
        let inlet = self.inlets.remove(index);
        self.intake.forget_channel(inlet.channel_key);
    }
}

impl<S: Service> Transport for IceoryxTransport<S>
where
    Listener<S>: SynchronousMultiplexing,
{
    fn backend(&self) -> Backend {
        self.backend
    }

    fn publish_with(
        &mut self,
        channel: &str,
        capacity: usize,
        write: &mut dyn FnMut(&mut [u8]) -> Option<usize>,
    ) -> Result<usize, PublishError> {
        check_publish(channel, capacity, self.config.max_payload)?;
        let publisher_id = self.publisher_id;
        let initial = self.config.initial_payload;
        let seal = self.seal.clone();
        let outlet = self.outlet(channel, initial)?;
        let reached = outlet.send_with(publisher_id, &seal, capacity, write)?;
        self.intake.stats.published += 1;
        Ok(reached)
    }

    fn publish(&mut self, channel: &str, payload: &[u8]) -> Result<usize, PublishError> {
        check_publish(channel, payload.len(), self.config.max_payload)?;
        let publisher_id = self.publisher_id;
        let initial = self.config.initial_payload;
        let seal = self.seal.clone();
        let reached = self
            .outlet(channel, initial)?
            .send_copy(publisher_id, &seal, payload)?;
        self.intake.stats.published += 1;
        Ok(reached)
    }

    fn forward(
        &mut self,
        channel: &str,
        origin: crate::Origin,
        payload: &[u8],
    ) -> Result<usize, PublishError> {
        check_publish(channel, payload.len(), self.config.max_payload)?;
        let initial = self.config.initial_payload;
        let reached = self
            .outlet(channel, initial)?
            .send_forwarded(origin, payload)?;
        self.intake.stats.published += 1;
        Ok(reached)
    }

    fn advertise(&mut self, channel: &str, expected_payload: usize) -> Result<(), PublishError> {
        validate_channel(channel)?;
        let initial = self.config.initial_payload.max(expected_payload);
        self.outlet(channel, initial).map(|_| ())
    }

    fn claim(&mut self, name: &str, holder: &str) -> Result<u64, ClaimError> {
        let claim = claim::Claim::take(&self.node, name, holder)?;
        self.claims.push(claim);
        Ok(claim::now_us())
    }

    fn keep_claims(&mut self) -> Result<(), ClaimError> {
        for claim in &self.claims {
            claim.keep();
        }
        Ok(())
    }

    fn subscribe(&mut self, channel: &str) -> Result<(), SubscribeError> {
        validate_channel(channel)?;
        match self.inlet_index(channel) {
            Some(index) => self.inlets[index].direct = true,
            None => self.add_inlet(channel, None)?,
        }
        Ok(())
    }

    fn unsubscribe(&mut self, channel: &str) -> Result<(), SubscribeError> {
        validate_channel(channel)?;
        if let Some(index) = self.inlet_index(channel) {
            if self.inlets[index].pattern.is_some() {
                self.inlets[index].direct = false;
            } else {
                self.remove_inlet(index);
            }
        }
        Ok(())
    }

    fn psubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError> {
        validate_channel(pattern)?;
        if !self.patterns.iter().any(|p| p == pattern) {
            self.patterns.push(pattern.to_owned());
        }
        self.discover();
        Ok(())
    }

    fn punsubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError> {
        validate_channel(pattern)?;
        self.patterns.retain(|p| p != pattern);
        let mut index = self.inlets.len();
        while index > 0 {
            index -= 1;
            if self.inlets[index].pattern.as_deref() == Some(pattern) {
                if self.inlets[index].direct {
                    self.inlets[index].pattern = None;
                } else {
                    self.remove_inlet(index);
                }
            }
        }
        Ok(())
    }

    fn try_receive(&mut self) -> Result<Option<Message<'_>>, ReceiveError> {
        self.advance()?;
        Ok(self.current_message())
    }

    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<Message<'_>>, ReceiveError> {
        let deadline = Instant::now() + timeout;
        while !self.advance()? {
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            let mut wait = deadline - now;
            if !self.patterns.is_empty() {
                wait = wait.min(self.next_discovery.saturating_duration_since(now));
            }
            self.wait_for_wakeup(wait)?;
        }
        Ok(self.current_message())
    }

    fn stats(&self) -> Stats {
        self.intake.stats
    }

    fn max_payload(&self) -> usize {
        self.config.max_payload
    }
}
