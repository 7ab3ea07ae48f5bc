//! What a receive returns.

/// A received message, borrowing its payload from the transport (on shared memory, from the
/// sample itself). It lives until the next call on the transport; use [`Message::to_owned`] to
/// keep it longer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Message<'a> {
    /// The channel it was published on.
    pub channel: &'a str,
    /// The pattern that matched, for a message received through `psubscribe`.
    pub pattern: Option<&'a str>,
    /// The bytes the publisher wrote.
    pub payload: &'a [u8],
}

impl Message<'_> {
    /// Copies the message out of the transport.
    pub fn to_owned(&self) -> OwnedMessage {
        OwnedMessage {
            channel: self.channel.to_owned(),
            pattern: self.pattern.map(str::to_owned),
            payload: self.payload.to_vec(),
        }
    }
}

/// A received message that owns its bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OwnedMessage {
    /// The channel it was published on.
    pub channel: String,
    /// The pattern that matched, for a message received through `psubscribe`.
    pub pattern: Option<String>,
    /// The bytes the publisher wrote.
    pub payload: Vec<u8>,
}
