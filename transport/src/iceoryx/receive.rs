//! Receiving: pattern discovery, the round-robin poll of the subscribers, and sleeping on
//! their listeners in a WaitSet.

use std::time::{Duration, Instant};

use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::*;
use iceoryx2::service::Service;
use iceoryx2::service::static_config::messaging_pattern::MessagingPattern as StaticPattern;

use super::IceoryxTransport;
use crate::Message;
use crate::error::ReceiveError;
use crate::pattern::glob_match;

impl<S: Service> IceoryxTransport<S>
where
    Listener<S>: SynchronousMultiplexing,
{
    /// Subscribes to every existing channel that matches a pattern and is not yet received.
    pub(super) fn discover(&mut self) {
        self.next_discovery = Instant::now() + self.config.discovery_interval;
        if self.patterns.is_empty() {
            return;
        }
        let mut found: Vec<(String, String)> = Vec::new();
        let _listed = S::list(self.node.config(), |details| {
            let name = details.static_details.name().as_str();
            if matches!(
                details.static_details.messaging_pattern(),
                StaticPattern::PublishSubscribe(_)
            ) && !self.unusable.contains(name)
                && !self.inlets.iter().any(|inlet| inlet.channel == name)
                && let Some(pattern) = self.patterns.iter().find(|p| glob_match(p, name))
            {
                found.push((name.to_owned(), pattern.clone()));
            }
            CallbackProgression::Continue
        });
        for (channel, pattern) in found {
            if self.add_inlet(&channel, Some(&pattern)).is_err() {
                // A service of another payload type (not a seam channel) or one already full:
                // remember it so discovery does not retry it every interval.
                self.unusable.insert(channel);
            }
        }
    }

    /// Takes the next valid sample into `self.current`; returns whether there was one.
    pub(super) fn advance(&mut self) -> Result<bool, ReceiveError> {
        self.current = None;
        if !self.patterns.is_empty() && Instant::now() >= self.next_discovery {
            self.discover();
        }
        let count = self.inlets.len();
        for k in 0..count {
            let index = (self.cursor + k) % count;
            loop {
                let inlet = &self.inlets[index];
                let sample = match inlet.subscriber.receive() {
                    Ok(Some(sample)) => sample,
                    Ok(None) => break,
                    Err(e) => {
                        return Err(ReceiveError::SharedMemory {
                            channel: inlet.channel.clone(),
                            reason: e.to_string(),
                        });
                    }
                };
                let envelope = *sample.user_header();
                if !envelope.is_valid() || envelope.len > sample.payload().len() as u64 {
                    self.intake.malformed();
                    continue;
                }
                let payload = &sample.payload()[..envelope.len as usize];
                if !self
                    .intake
                    .accept(inlet.channel_key, &inlet.channel, &envelope, payload)
                {
                    continue;
                }
                self.cursor = index + 1;
                self.current = Some((index, sample));
                return Ok(true);
            }
        }
        Ok(false)
    }

    pub(super) fn current_message(&self) -> Option<Message<'_>> {
        let (index, sample) = self.current.as_ref()?;
        let inlet = &self.inlets[*index];
        let len = sample.user_header().len as usize;
        Some(Message {
            channel: &inlet.channel,
            pattern: if inlet.direct {
                None
            } else {
                inlet.pattern.as_deref()
            },
            payload: &sample.payload()[..len],
            origin: sample.user_header().origin(),
            signer: self.intake.checked_signer(&sample.user_header().origin()),
        })
    }

    /// Sleeps until a listener is notified or `timeout` passes.
    pub(super) fn wait_for_wakeup(&mut self, timeout: Duration) -> Result<(), ReceiveError> {
        let shm_error = |reason: String| ReceiveError::SharedMemory {
            channel: String::new(),
            reason,
        };
        if self.inlets.is_empty() {
            // Nothing can arrive; only discovery (driven by the caller's loop) can change that.
            std::thread::sleep(timeout);
            return Ok(());
        }
        {
            let waitset = WaitSetBuilder::new()
                .signal_handling_mode(SignalHandlingMode::Disabled)
                .create::<S>()
                .map_err(|e| shm_error(e.to_string()))?;
            let guards = self
                .inlets
                .iter()
                .map(|inlet| waitset.attach_notification(&inlet.listener))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| shm_error(e.to_string()))?;
            waitset
                .wait_and_process_once_with_timeout(|_| CallbackProgression::Stop, timeout)
                .map_err(|e| shm_error(e.to_string()))?;
            drop(guards);
        }
        // Consume the wake-ups so the next notify sends a datagram again; samples are checked
        // after this, so none published meanwhile is missed.
        for inlet in &self.inlets {
            let _ = inlet.listener.try_wait(|_| {});
        }
        Ok(())
    }
}
