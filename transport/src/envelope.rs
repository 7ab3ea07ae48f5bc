//! The envelope every seam message travels in, on every backend.
//!
//! It names the publishing transport, numbers the publisher's messages per channel, gives the
//! payload length and carries the message's keyed tag (all zero without a key; see
//! [`crate::auth`]) and its signer and signature (all zero unsigned; see [`crate::signing`]). Gaps in the numbering are how a receiver counts messages it lost to a full
//! buffer; bytes that do not start with a valid envelope are counted as malformed and skipped.
//! On shared memory the envelope is the iceoryx2 user header (the payload stays the caller's
//! bytes, zero copy); on Redis it is the first [`Envelope::WIRE_LEN`] bytes of the message.

use std::collections::HashMap;
use std::hash::{BuildHasher, Hash, Hasher};

use iceoryx2::prelude::ZeroCopySend;

/// The envelope format version; a receiver drops envelopes of another version as malformed.
pub const ENVELOPE_VERSION: u32 = 3;
const MAGIC: u32 = u32::from_le_bytes(*b"seam");

/// Header of one message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("seam::Envelope")]
pub struct Envelope {
    /// Always `b"seam"`; tells a seam message from foreign bytes.
    pub magic: u32,
    /// [`ENVELOPE_VERSION`] of the publisher.
    pub version: u32,
    /// Random identity of the publishing transport instance.
    pub publisher: u64,
    /// 1 for the publisher's first message on this channel, then +1 per message.
    pub seq: u64,
    /// Payload length in bytes (on shm the loaned slice may be longer).
    pub len: u64,
    /// Keyed tag over the channel, the fields above and the payload (see [`crate::auth`]).
    pub tag: crate::auth::Tag,
    /// The signer's identity, little-endian (zero unsigned; see [`crate::signing`]).
    pub signer: [u8; 16],
    /// ed25519 signature over the channel, the fields above but the tag, and the payload.
    pub signature: crate::signing::SignatureBytes,
}

impl Default for Envelope {
    fn default() -> Self {
        Self {
            magic: 0,
            version: 0,
            publisher: 0,
            seq: 0,
            len: 0,
            tag: [0; crate::auth::TAG_LEN],
            signer: [0; 16],
            signature: [0; crate::signing::SIGNATURE_LEN],
        }
    }
}

impl Envelope {
    /// Bytes the envelope takes on a byte-stream backend.
    pub const WIRE_LEN: usize = 128;

    /// An untagged envelope for message `seq` of `publisher` with `len` payload bytes.
    pub fn new(publisher: u64, seq: u64, len: usize) -> Self {
        Self {
            magic: MAGIC,
            version: ENVELOPE_VERSION,
            publisher,
            seq,
            len: len as u64,
            ..Self::default()
        }
    }

    /// The envelope of message `seq` of `publisher` carrying `payload` on `channel`, tagged
    /// with the seal's key and signed by its signer, where it has them.
    pub(crate) fn sealed(
        seal: &Seal,
        channel: &str,
        publisher: u64,
        seq: u64,
        payload: &[u8],
    ) -> Self {
        let mut envelope = Self::new(publisher, seq, payload.len());
        if let Some(key) = &seal.key {
            envelope.tag = key.tag(channel, publisher, seq, payload);
        }
        if let Some(signer) = &seal.signer {
            envelope.signer = signer.id().to_le_bytes();
            let digest = crate::signing::digest(channel, publisher, seq, signer.id(), payload);
            envelope.signature = signer.sign(&digest);
        }
        envelope
    }

    /// The envelope of a message passed on unchanged: `origin`'s publisher, number, tag,
    /// signer and signature.
    pub fn forwarded(origin: crate::Origin, len: usize) -> Self {
        Self {
            tag: origin.tag,
            signer: origin.signer.to_le_bytes(),
            signature: origin.signature,
            ..Self::new(origin.publisher, origin.seq, len)
        }
    }

    /// The publisher, number, tag, signer and signature this envelope carries.
    pub fn origin(&self) -> crate::Origin {
        crate::Origin {
            publisher: self.publisher,
            seq: self.seq,
            tag: self.tag,
            signer: u128::from_le_bytes(self.signer),
            signature: self.signature,
        }
    }

    /// Whether this header came from a seam publisher of this version.
    pub fn is_valid(&self) -> bool {
        self.magic == MAGIC && self.version == ENVELOPE_VERSION && self.seq != 0
    }

    /// Writes the wire form into the first [`Self::WIRE_LEN`] bytes of `out`.
    pub fn write_to(&self, out: &mut [u8; Self::WIRE_LEN]) {
        out[0..4].copy_from_slice(&self.magic.to_le_bytes());
        out[4..8].copy_from_slice(&self.version.to_le_bytes());
        out[8..16].copy_from_slice(&self.publisher.to_le_bytes());
        out[16..24].copy_from_slice(&self.seq.to_le_bytes());
        out[24..32].copy_from_slice(&self.len.to_le_bytes());
        out[32..48].copy_from_slice(&self.tag);
        out[48..64].copy_from_slice(&self.signer);
        out[64..128].copy_from_slice(&self.signature);
    }

    /// Splits a wire message into its valid envelope and payload, or `None` if it is not one.
    pub fn split(bytes: &[u8]) -> Option<(Self, &[u8])> {
        let (head, payload) = bytes.split_at_checked(Self::WIRE_LEN)?;
        let word = |at: usize| u64::from_le_bytes(head[at..at + 8].try_into().unwrap_or_default());
        let envelope = Self {
            magic: u32::from_le_bytes(head[0..4].try_into().unwrap_or_default()),
            version: u32::from_le_bytes(head[4..8].try_into().unwrap_or_default()),
            publisher: word(8),
            seq: word(16),
            len: word(24),
            tag: head[32..48].try_into().unwrap_or_default(),
            signer: head[48..64].try_into().unwrap_or_default(),
            signature: head[64..128]
                .try_into()
                .unwrap_or([0; crate::signing::SIGNATURE_LEN]),
        };
        (envelope.is_valid() && envelope.len == payload.len() as u64).then_some((envelope, payload))
    }
}

/// A random identity for a publishing transport, from the OS-seeded keys of std's hasher.
pub(crate) fn random_publisher_id() -> u64 {
    let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
    std::process::id().hash(&mut hasher);
    std::time::Instant::now().hash(&mut hasher);
    hasher.finish()
}

/// Numbers outgoing messages per channel.
#[derive(Debug, Default)]
pub(crate) struct SeqCounter {
    next: HashMap<String, u64>,
}

impl SeqCounter {
    /// The number for the next message on `channel`, starting at 1.
    pub(crate) fn next(&mut self, channel: &str) -> u64 {
        // Look up by &str first so the steady state does not allocate.
        if let Some(seq) = self.next.get_mut(channel) {
            *seq += 1;
            return *seq;
        }
        self.next.insert(channel.to_owned(), 1);
        1
    }
}

/// Finds gaps in the numbering of each publisher on each channel. Channels are known by a key
/// from [`GapDetector::channel_key`], which a backend may compute once per subscription.
#[derive(Debug, Default)]
pub(crate) struct GapDetector {
    last: HashMap<(u64, u64), u64>,
    hasher: std::collections::hash_map::RandomState,
}

impl GapDetector {
    /// The key of `channel`.
    pub(crate) fn channel_key(&self, channel: &str) -> u64 {
        self.hasher.hash_one(channel)
    }

    /// Records `envelope` received on the channel with key `channel`; returns how many messages
    /// went missing just before it. The first message from a publisher on a channel sets the
    /// baseline.
    pub(crate) fn observe(&mut self, channel: u64, envelope: &Envelope) -> u64 {
        match self
            .last
            .insert((envelope.publisher, channel), envelope.seq)
        {
            Some(last) if envelope.seq > last => envelope.seq - last - 1,
            _ => 0,
        }
    }

    /// Forgets the numbering of a channel (after an unsubscribe, a later gap is not a drop).
    pub(crate) fn forget_channel(&mut self, channel: u64) {
        self.last.retain(|(_, c), _| *c != channel);
    }
}

/// What a publishing transport seals its envelopes with: the deployment's key (tags) and its
/// own signer (signatures), each where it has one.
#[derive(Debug, Default)]
pub(crate) struct Seal {
    pub(crate) key: Option<crate::auth::FrameKey>,
    pub(crate) signer: Option<crate::signing::Signer>,
}

impl Seal {
    /// The seal of a transport with `key` and `signing`'s signer.
    pub(crate) fn new(
        key: Option<crate::auth::FrameKey>,
        signing: &crate::signing::Signing,
    ) -> std::sync::Arc<Self> {
        std::sync::Arc::new(Self {
            key,
            signer: signing.signer.clone(),
        })
    }
}

/// A transport's bookkeeping: the counters of [`crate::Stats`], the sequence gaps that feed
/// `overflow_drops`, the frame key that checks tags and the keyring that checks signatures.
#[derive(Debug, Default)]
pub(crate) struct Intake {
    gaps: GapDetector,
    /// The counters; backends add to `published` themselves.
    pub(crate) stats: crate::Stats,
    /// The deployment's key: messages without its tag are dropped.
    key: Option<crate::auth::FrameKey>,
    /// The signers trusted: messages none of them signed are dropped.
    keyring: Option<crate::signing::Keyring>,
}

impl Intake {
    /// Bookkeeping that checks tags with `key` and signatures with `keyring`, each if given.
    pub(crate) fn new(
        key: Option<crate::auth::FrameKey>,
        keyring: Option<crate::signing::Keyring>,
    ) -> Self {
        Self {
            key,
            keyring,
            ..Self::default()
        }
    }

    /// The signer of an accepted message, where this intake checked it against a keyring.
    pub(crate) fn checked_signer(&self, origin: &crate::Origin) -> Option<u128> {
        self.keyring.as_ref().map(|_| origin.signer)
    }

    /// The key of `channel` for [`Self::accept`] and [`Self::forget_channel`].
    pub(crate) fn channel_key(&self, channel: &str) -> u64 {
        self.gaps.channel_key(channel)
    }

    /// Checks a well-formed message received on `name` (whose key is `channel`) against the
    /// frame key and the keyring, where there are; counts it, with the messages lost before
    /// it, and returns true if it may be handed over; counts the drop and returns false if not.
    pub(crate) fn accept(
        &mut self,
        channel: u64,
        name: &str,
        envelope: &Envelope,
        payload: &[u8],
    ) -> bool {
        if let Some(key) = &self.key {
            match key.check(
                name,
                envelope.publisher,
                envelope.seq,
                payload,
                &envelope.tag,
            ) {
                crate::auth::Verdict::Good => {}
                crate::auth::Verdict::Untagged => {
                    self.stats.untagged_drops += 1;
                    return false;
                }
                crate::auth::Verdict::Wrong => {
                    self.stats.bad_tag_drops += 1;
                    return false;
                }
            }
        }
        if let Some(keyring) = &self.keyring {
            let signer = u128::from_le_bytes(envelope.signer);
            let digest =
                crate::signing::digest(name, envelope.publisher, envelope.seq, signer, payload);
            match keyring.check(signer, &digest, &envelope.signature) {
                crate::signing::SignVerdict::Good => {}
                crate::signing::SignVerdict::Unsigned => {
                    self.stats.unsigned_drops += 1;
                    return false;
                }
                crate::signing::SignVerdict::Forged => {
                    self.stats.forged_drops += 1;
                    return false;
                }
            }
        }
        self.stats.overflow_drops += self.gaps.observe(channel, envelope);
        self.stats.received += 1;
        true
    }

    /// Counts bytes that were not a valid seam message.
    pub(crate) fn malformed(&mut self) {
        self.stats.malformed_drops += 1;
    }

    /// Forgets the numbering of the channel with key `channel` after an unsubscribe.
    pub(crate) fn forget_channel(&mut self, channel: u64) {
        self.gaps.forget_channel(channel);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wire_round_trip() {
        let envelope = Envelope::new(7, 3, 5);
        let mut bytes = [0u8; Envelope::WIRE_LEN + 5];
        let head: &mut [u8; Envelope::WIRE_LEN] = (&mut bytes[..Envelope::WIRE_LEN])
            .try_into()
            .expect("exact length");
        envelope.write_to(head);
        bytes[Envelope::WIRE_LEN..].copy_from_slice(b"hello");
        assert_eq!(Envelope::split(&bytes), Some((envelope, &b"hello"[..])));
    }

    #[test]
    fn foreign_bytes_are_not_envelopes() {
        assert_eq!(Envelope::split(b"hello"), None);
        assert_eq!(Envelope::split(&[0u8; 64]), None);
        let mut bytes = [0u8; Envelope::WIRE_LEN + 4];
        let head: &mut [u8; Envelope::WIRE_LEN] = (&mut bytes[..Envelope::WIRE_LEN])
            .try_into()
            .expect("exact length");
        Envelope::new(1, 1, 5).write_to(head);
        assert_eq!(Envelope::split(&bytes), None, "length must match");
    }

    #[test]
    fn gaps_are_counted_per_publisher_and_channel() {
        let mut gaps = GapDetector::default();
        let (a, b) = (gaps.channel_key("a"), gaps.channel_key("b"));
        assert_eq!(gaps.observe(a, &Envelope::new(1, 1, 0)), 0);
        assert_eq!(gaps.observe(a, &Envelope::new(1, 2, 0)), 0);
        assert_eq!(gaps.observe(a, &Envelope::new(1, 5, 0)), 2);
        assert_eq!(gaps.observe(b, &Envelope::new(1, 9, 0)), 0, "baseline");
        assert_eq!(gaps.observe(a, &Envelope::new(2, 4, 0)), 0, "baseline");
        gaps.forget_channel(a);
        assert_eq!(gaps.observe(a, &Envelope::new(1, 9, 0)), 0);
    }
}
