//! The iceoryx2 ports behind one channel: an outlet to publish, an inlet to receive.

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::sample::Sample;
use iceoryx2::sample_mut::SampleMut;
use iceoryx2::service::Service;
use iceoryx2::service::builder::event::EventOpenOrCreateError;
use iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenOrCreateError;
use iceoryx2::service::port_factory::{event, publish_subscribe};

use super::IceoryxConfig;
use crate::envelope::{Envelope, Seal};
use crate::error::PublishError;

/// A received sample: the caller's bytes with the seam envelope as user header.
pub(super) type InSample<S> = Sample<S, [u8], Envelope>;

/// Why a port could not be made.
pub(super) enum PortError {
    /// The service exists with settings or a type seam cannot use.
    Incompatible(String),
    /// The service refused the port or could not be created.
    Unavailable(String),
}

/// The data service and the wake-up service behind one channel.
type ChannelServices<S> = (
    publish_subscribe::PortFactory<S, [u8], Envelope>,
    event::PortFactory<S>,
);

/// Opens (or creates with seam's limits) the two services behind `channel`.
fn services<S: Service>(
    node: &Node<S>,
    config: &IceoryxConfig,
    channel: &str,
) -> Result<ChannelServices<S>, PortError> {
    let name = ServiceName::new(channel).map_err(|e| PortError::Unavailable(format!("{e:?}")))?;
    let nodes = config.max_publishers + config.max_subscribers;
    let data = node
        .service_builder(&name)
        .publish_subscribe::<[u8]>()
        .user_header::<Envelope>()
        .max_publishers(config.max_publishers)
        .max_subscribers(config.max_subscribers)
        .max_nodes(nodes)
        .subscriber_max_buffer_size(config.buffer)
        .subscriber_max_borrowed_samples(2)
        .history_size(0)
        // A full subscriber buffer drops its oldest sample: newest data wins and a slow receiver
        // never blocks a publisher. The receiver counts the loss from sequence gaps.
        .enable_safe_overflow(true)
        .open_or_create()
        .map_err(|e| match e {
            PublishSubscribeOpenOrCreateError::PublishSubscribeOpenError(open) => {
                PortError::Incompatible(open.to_string())
            }
            other => PortError::Unavailable(other.to_string()),
        })?;
    let wake = node
        .service_builder(&name)
        .event()
        .max_notifiers(config.max_publishers)
        .max_listeners(config.max_subscribers)
        .max_nodes(nodes)
        .open_or_create()
        .map_err(|e| match e {
            EventOpenOrCreateError::EventOpenError(open) => {
                PortError::Incompatible(open.to_string())
            }
            other => PortError::Unavailable(other.to_string()),
        })?;
    Ok((data, wake))
}

/// The publishing side of one channel.
pub(super) struct Outlet<S: Service> {
    channel: String,
    publisher: Publisher<S, [u8], Envelope>,
    notifier: Notifier<S>,
    seq: u64,
}

impl<S: Service> Outlet<S> {
    /// A publisher on `channel` whose first shared memory holds `initial_len` bytes (capped at
    /// the maximum payload); it grows by powers of two when a larger payload comes.
    pub(super) fn create(
        node: &Node<S>,
        config: &IceoryxConfig,
        channel: &str,
        initial_len: usize,
    ) -> Result<Self, PortError> {
        let (data, wake) = services(node, config, channel)?;
        let publisher = data
            .publisher_builder()
            .initial_max_slice_len(initial_len.min(config.max_payload))
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| PortError::Unavailable(e.to_string()))?;
        let notifier = wake
            .notifier_builder()
            .create()
            .map_err(|e| PortError::Unavailable(e.to_string()))?;
        Ok(Self {
            channel: channel.to_owned(),
            publisher,
            notifier,
            seq: 0,
        })
    }

    fn unavailable(&self, reason: String) -> PublishError {
        PublishError::PortUnavailable {
            channel: self.channel.clone(),
            reason,
        }
    }

    /// Loans a sample of `capacity` bytes, lets `write` fill it, sends it and wakes listeners.
    /// Returns the number of subscribers reached.
    pub(super) fn send_with(
        &mut self,
        publisher_id: u64,
        seal: &Seal,
        capacity: usize,
        write: &mut dyn FnMut(&mut [u8]) -> Option<usize>,
    ) -> Result<usize, PublishError> {
        let sample = self
            .publisher
            .loan_slice_uninit(capacity)
            .map_err(|e| self.unavailable(e.to_string()))?;
        // The writer gets `&mut [u8]`, so the loan is initialised first (a memset of `capacity`
        // bytes, cheap next to encoding into it).
        let mut sample = sample.write_from_fn(|_| 0u8);
        let written = write(sample.payload_mut()).ok_or(PublishError::WriterAborted)?;
        if written > capacity {
            return Err(PublishError::WriterOverrun { written, capacity });
        }
        self.finish(publisher_id, seal, written, sample)
    }

    /// Copies `payload` into a loaned sample, sends it and wakes listeners.
    pub(super) fn send_copy(
        &mut self,
        publisher_id: u64,
        seal: &Seal,
        payload: &[u8],
    ) -> Result<usize, PublishError> {
        let sample = self.loan_copy(payload)?;
        self.finish(publisher_id, seal, payload.len(), sample)
    }

    /// A loaned sample holding a copy of `payload`.
    fn loan_copy(&mut self, payload: &[u8]) -> Result<SampleMut<S, [u8], Envelope>, PublishError> {
        let sample = self
            .publisher
            .loan_slice_uninit(payload.len())
            .map_err(|e| self.unavailable(e.to_string()))?;
        Ok(sample.write_from_slice(payload))
    }

    fn finish(
        &mut self,
        publisher_id: u64,
        seal: &Seal,
        written: usize,
        sample: SampleMut<S, [u8], Envelope>,
    ) -> Result<usize, PublishError> {
        self.seq += 1;
        let envelope = Envelope::sealed(
            seal,
            &self.channel,
            publisher_id,
            self.seq,
            &sample.payload()[..written],
        );
        self.send(envelope, sample)
    }

    /// Copies a message received elsewhere into a loaned sample under its own envelope, sends
    /// it and wakes listeners; this outlet's numbering is not advanced.
    pub(super) fn send_forwarded(
        &mut self,
        origin: crate::Origin,
        payload: &[u8],
    ) -> Result<usize, PublishError> {
        let sample = self.loan_copy(payload)?;
        self.send(Envelope::forwarded(origin, payload.len()), sample)
    }

    fn send(
        &mut self,
        envelope: Envelope,
        mut sample: SampleMut<S, [u8], Envelope>,
    ) -> Result<usize, PublishError> {
        *sample.user_header_mut() = envelope;
        let reached = sample.send().map_err(|e| self.unavailable(e.to_string()))?;
        // A failed wake-up (a listener's socket full) loses nothing: the sample is delivered and
        // that listener is already awake with wake-ups pending.
        let _ = self.notifier.notify();
        Ok(reached)
    }
}

/// The receiving side of one channel.
pub(super) struct Inlet<S: Service> {
    pub(super) channel: String,
    /// Key of `channel` for sequence-gap bookkeeping, computed once.
    pub(super) channel_key: u64,
    /// The pattern that led to this subscription, if a pattern did.
    pub(super) pattern: Option<String>,
    /// Whether the channel is also subscribed by name.
    pub(super) direct: bool,
    pub(super) subscriber: Subscriber<S, [u8], Envelope>,
    pub(super) listener: Listener<S>,
}

impl<S: Service> Inlet<S> {
    pub(super) fn create(
        node: &Node<S>,
        config: &IceoryxConfig,
        channel: &str,
        pattern: Option<&str>,
        channel_key: u64,
    ) -> Result<Self, PortError> {
        let (data, wake) = services(node, config, channel)?;
        let subscriber = data
            .subscriber_builder()
            .buffer_size(config.buffer)
            .create()
            .map_err(|e| PortError::Unavailable(e.to_string()))?;
        let listener = wake
            .listener_builder()
            .create()
            .map_err(|e| PortError::Unavailable(e.to_string()))?;
        Ok(Self {
            channel: channel.to_owned(),
            channel_key,
            pattern: pattern.map(str::to_owned),
            direct: pattern.is_none(),
            subscriber,
            listener,
        })
    }
}
