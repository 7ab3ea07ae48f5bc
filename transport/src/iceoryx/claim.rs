//! Claims on iceoryx2: a publish-subscribe service named `claim:NAME` that admits one
//! publisher. The holder's publisher keeps its description as the service's history, so a
//! transport refused reads who holds the name from a subscriber. A holder that was killed
//! leaves its publisher registered until iceoryx2's dead-node cleanup removes it, which a
//! refused claim runs once before giving up.

use std::time::{Duration, Instant};

use iceoryx2::port::publisher::{Publisher, PublisherCreateError};
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;
use iceoryx2::service::Service;
use iceoryx2::service::port_factory::publish_subscribe;

use crate::error::ClaimError;

/// How long a refused claim waits for the holder to say who it is.
const HOLDER_WAIT: Duration = Duration::from_millis(300);

/// Longest holder description kept.
const MAX_HOLDER_LEN: usize = 512;

/// This host's clock now, microseconds since the UNIX epoch: a claim's incarnation (see
/// [`crate::Transport::claim`]).
pub(super) fn now_us() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64)
}

/// A name this transport holds.
pub(super) struct Claim<S: Service> {
    publisher: Publisher<S, [u8], ()>,
}

impl<S: Service> Claim<S> {
    /// Takes `name` for `holder` through `node`, or says who holds it.
    pub(super) fn take(node: &Node<S>, name: &str, holder: &str) -> Result<Self, ClaimError> {
        let unavailable = |reason: String| ClaimError::Unavailable {
            name: name.to_owned(),
            reason,
        };
        let service = service(node, name).map_err(unavailable)?;
        let holder = &holder.as_bytes()[..holder.len().min(MAX_HOLDER_LEN)];
        let create = || {
            service
                .publisher_builder()
                .initial_max_slice_len(holder.len().max(1))
                .create()
        };
        let publisher = match create() {
            Ok(publisher) => publisher,
            Err(PublisherCreateError::ExceedsMaxSupportedPublishers) => {
                // A holder killed without closing leaves its publisher behind.
                node.try_cleanup_dead_nodes();
                match create() {
                    Ok(publisher) => publisher,
                    Err(PublisherCreateError::ExceedsMaxSupportedPublishers) => {
                        return Err(ClaimError::Held {
                            name: name.to_owned(),
                            holder: read_holder(&service),
                        });
                    }
                    Err(e) => return Err(unavailable(e.to_string())),
                }
            }
            Err(e) => return Err(unavailable(e.to_string())),
        };
        let sample = publisher
            .loan_slice_uninit(holder.len())
            .map_err(|e| unavailable(e.to_string()))?;
        sample
            .write_from_slice(holder)
            .send()
            .map_err(|e| unavailable(e.to_string()))?;
        Ok(Self { publisher })
    }

    /// Hands the holder's description to transports that asked since the last call.
    pub(super) fn keep(&self) {
        let _ = self.publisher.update_connections();
    }
}

/// The claim service behind `name`: one publisher, its last sample kept for new subscribers.
fn service<S: Service>(
    node: &Node<S>,
    name: &str,
) -> Result<publish_subscribe::PortFactory<S, [u8], ()>, String> {
    let service_name = ServiceName::new(&format!("claim:{name}")).map_err(|e| format!("{e:?}"))?;
    node.service_builder(&service_name)
        .publish_subscribe::<[u8]>()
        .max_publishers(1)
        .max_subscribers(8)
        .max_nodes(9)
        .history_size(1)
        .subscriber_max_buffer_size(1)
        .subscriber_max_borrowed_samples(1)
        .open_or_create()
        .map_err(|e| e.to_string())
}

/// Who holds the claim of `service`, as its holder described itself (read from the history its
/// publisher hands new subscribers when it next keeps its claim, so this waits a little).
fn read_holder<S: Service>(service: &publish_subscribe::PortFactory<S, [u8], ()>) -> String {
    let unknown = "another live process (it has not said who)".to_owned();
    let Ok(subscriber) = service.subscriber_builder().create() else {
        return unknown;
    };
    let deadline = Instant::now() + HOLDER_WAIT;
    while Instant::now() < deadline {
        if let Ok(Some(sample)) = subscriber.receive() {
            return String::from_utf8_lossy(sample.payload()).into_owned();
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    unknown
}
