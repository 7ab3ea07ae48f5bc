//! Settings of the iceoryx2 backends, read from the transport URL's query.

use std::time::Duration;

use crate::url::SettingError;

/// Quality of service and limits of the shared-memory (`shm`) and in-process (`local`) backends.
///
/// iceoryx2 fixes a service's limits when the first port creates it; a later pod that asks for
/// more than the service has gets [`crate::SubscribeError::IncompatibleService`]. Every pod on a
/// host must therefore use the same settings, which is why they live in the transport URL.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IceoryxConfig {
    /// iceoryx2 file prefix; pods see each other only with the same prefix. Tests isolate
    /// themselves with a unique one.
    pub prefix: String,
    /// Largest payload, in bytes, a publish accepts.
    pub max_payload: usize,
    /// Payload size the first shared-memory segment of a publisher is sized for; larger payloads
    /// grow it (power-of-two reallocation), so this trades start-up memory for early resizes.
    pub initial_payload: usize,
    /// Publishers one channel can have (a `physics_events` channel has one per neighbour).
    pub max_publishers: usize,
    /// Subscribers one channel can have.
    pub max_subscribers: usize,
    /// Messages a subscriber buffers before the oldest is overwritten (a counted drop).
    pub buffer: usize,
    /// How often pattern subscriptions look for new channels.
    pub discovery_interval: Duration,
    /// The deployment's frame key (`key=` or `key_file=`; see [`crate::auth`]).
    pub key: Option<crate::auth::FrameKey>,
    /// This pod's signer and the keyring it checks with (`sign_key=`, `keyring=`; see
    /// [`crate::signing`]).
    pub signing: crate::signing::Signing,
}

impl Default for IceoryxConfig {
    fn default() -> Self {
        Self {
            prefix: "seam_".to_owned(),
            max_payload: 4 << 20,
            initial_payload: 4096,
            max_publishers: 16,
            max_subscribers: 16,
            buffer: 16,
            discovery_interval: Duration::from_millis(50),
            key: None,
            signing: crate::signing::Signing::default(),
        }
    }
}

impl IceoryxConfig {
    /// Applies one `key=value` pair from a transport URL.
    pub(crate) fn set(&mut self, key: &str, value: &str) -> Result<(), SettingError> {
        if let Some(frame_key) = crate::auth::FrameKey::from_setting(key, value) {
            self.key = Some(frame_key?);
            return Ok(());
        }
        if let Some(result) = self.signing.set(key, value) {
            return result;
        }
        let number = || {
            value
                .parse::<usize>()
                .ok()
                .filter(|n| *n > 0)
                .ok_or_else(|| SettingError::NotPositive {
                    key: key.to_owned(),
                    value: value.to_owned(),
                })
        };
        match key {
            "prefix" => {
                let valid = !value.is_empty()
                    && value.len() <= 64
                    && value
                        .bytes()
                        .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-' || b == b'.');
                if !valid {
                    return Err(SettingError::Prefix {
                        value: value.to_owned(),
                    });
                }
                self.prefix = value.to_owned();
            }
            "max_payload" => self.max_payload = number()?,
            "initial_payload" => self.initial_payload = number()?,
            "max_publishers" => self.max_publishers = number()?,
            "max_subscribers" => self.max_subscribers = number()?,
            "buffer" => self.buffer = number()?,
            "discovery_ms" => self.discovery_interval = Duration::from_millis(number()? as u64),
            _ => {
                return Err(SettingError::Unknown {
                    key: key.to_owned(),
                    known: "prefix, max_payload, initial_payload, max_publishers, \
                            max_subscribers, buffer, discovery_ms, key, key_file, sign_key, \
                            keyring",
                });
            }
        }
        Ok(())
    }
}
