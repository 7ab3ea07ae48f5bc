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
    /// Who published it and its number on the channel, from its envelope.
    pub origin: Origin,
    /// The signer whose signature the receiving transport checked against its keyring; `None`
    /// from a transport with no keyring (which checks no signature; see [`crate::signing`]).
    pub signer: Option<u128>,
}

/// The publisher and sequence number a message's envelope carries. A bridge that passes a
/// message on keeps them ([`crate::Transport::forward`]), so the final receiver still counts
/// gaps per original publisher.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Origin {
    /// Random identity of the publishing transport.
    pub publisher: u64,
    /// The publisher's number for this message on its channel, from 1.
    pub seq: u64,
    /// Its keyed tag (all zero from a publisher without a key; see [`crate::auth`]).
    pub tag: crate::auth::Tag,
    /// The signer it names (zero unsigned; see [`crate::signing`]).
    pub signer: u128,
    /// Its signature (all zero unsigned).
    pub signature: crate::signing::SignatureBytes,
}

impl Message<'_> {
    /// Copies the message out of the transport.
    pub fn to_owned(&self) -> OwnedMessage {
        OwnedMessage {
            channel: self.channel.to_owned(),
            pattern: self.pattern.map(str::to_owned),
            payload: self.payload.to_vec(),
            origin: self.origin,
            signer: self.signer,
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
    /// Who published it and its number on the channel.
    pub origin: Origin,
    /// The signer the receiving transport checked, if it checks signatures.
    pub signer: Option<u128>,
}
