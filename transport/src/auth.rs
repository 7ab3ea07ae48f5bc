//! Authenticated frames: an optional per-deployment key, and the keyed tag every message
//! carries in its envelope when one is set.
//!
//! The tag is the first 16 bytes of a BLAKE3 keyed hash over the channel name, the envelope's
//! publisher, number and length, and the payload — so a message cannot be replayed on another
//! channel, renumbered or cut. A transport with a key checks it on every message before handing
//! it over, and drops (counting why) a message with no tag (`Stats::untagged_drops`) or a wrong
//! one (`Stats::bad_tag_drops`). Without a key, tags are not checked and messages are published
//! with a zero tag. A bridge passes tags on unchanged ([`crate::Transport::forward`]), so it
//! need not hold the key for the frames it carries to stay authenticated end to end.
//!
//! The key comes from the transport URL: `key=SECRET` (any text; both ends derive the same
//! 32-byte key from it with BLAKE3's key derivation) or `key_file=PATH` (the file's bytes,
//! trailing newline ignored). URLs are redacted with the key hidden.

use std::fmt;

use crate::url::SettingError;

/// Bytes of a message tag.
pub const TAG_LEN: usize = 16;

/// A message tag; all zero when the publisher had no key.
pub type Tag = [u8; TAG_LEN];

/// BLAKE3 key-derivation context: a deployment's secret becomes its frame key through it.
const CONTEXT: &str = "seam 2026-12 frame tag v1";

/// A deployment's frame key.
#[derive(Clone, PartialEq, Eq)]
pub struct FrameKey([u8; 32]);

impl fmt::Debug for FrameKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("FrameKey(***)")
    }
}

impl FrameKey {
    /// The key derived from a secret (text or a key file's bytes).
    pub fn derive(secret: &[u8]) -> Self {
        Self(blake3::derive_key(CONTEXT, secret))
    }

    /// The key a URL setting names: `key=SECRET` or `key_file=PATH`; `None` for another
    /// setting.
    pub(crate) fn from_setting(key: &str, value: &str) -> Option<Result<Self, SettingError>> {
        match key {
            "key" if value.is_empty() => Some(Err(SettingError::EmptyKey)),
            "key" => Some(Ok(Self::derive(value.as_bytes()))),
            "key_file" => Some(Self::read_file(value)),
            _ => None,
        }
    }

    /// The key a key file holds (its bytes, a trailing newline ignored).
    fn read_file(path: &str) -> Result<Self, SettingError> {
        let bytes = std::fs::read(path).map_err(|source| SettingError::KeyFile {
            path: path.to_owned(),
            source,
        })?;
        let secret = bytes.strip_suffix(b"\n").unwrap_or(&bytes);
        if secret.is_empty() {
            return Err(SettingError::EmptyKeyFile {
                path: path.to_owned(),
            });
        }
        Ok(Self::derive(secret))
    }

    /// The tag of a message: `payload` published by `publisher` as number `seq` on `channel`.
    pub fn tag(&self, channel: &str, publisher: u64, seq: u64, payload: &[u8]) -> Tag {
        let mut hasher = blake3::Hasher::new_keyed(&self.0);
        hasher.update(&(channel.len() as u64).to_le_bytes());
        hasher.update(channel.as_bytes());
        hasher.update(&publisher.to_le_bytes());
        hasher.update(&seq.to_le_bytes());
        hasher.update(&(payload.len() as u64).to_le_bytes());
        hasher.update(payload);
        let mut tag = [0u8; TAG_LEN];
        tag.copy_from_slice(&hasher.finalize().as_bytes()[..TAG_LEN]);
        tag
    }

    /// Checks `tag` in constant time (as far as the comparison goes).
    pub fn check(
        &self,
        channel: &str,
        publisher: u64,
        seq: u64,
        payload: &[u8],
        tag: &Tag,
    ) -> Verdict {
        if tag == &[0u8; TAG_LEN] {
            return Verdict::Untagged;
        }
        let expected = self.tag(channel, publisher, seq, payload);
        let diff = expected
            .iter()
            .zip(tag)
            .fold(0u8, |acc, (a, b)| acc | (a ^ b));
        if diff == 0 {
            Verdict::Good
        } else {
            Verdict::Wrong
        }
    }
}

/// What checking a message's tag found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// The tag is right.
    Good,
    /// No tag: the publisher had no key.
    Untagged,
    /// A tag made with another key, or a message changed on the way.
    Wrong,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_bind_key_channel_numbering_and_payload() {
        let key = FrameKey::derive(b"deployment secret");
        let tag = key.tag("replication:1", 7, 3, b"payload");
        assert_eq!(
            key.check("replication:1", 7, 3, b"payload", &tag),
            Verdict::Good
        );
        for (channel, publisher, seq, payload) in [
            ("replication:2", 7, 3, &b"payload"[..]),
            ("replication:1", 8, 3, b"payload"),
            ("replication:1", 7, 4, b"payload"),
            ("replication:1", 7, 3, b"paylo"),
        ] {
            assert_eq!(
                key.check(channel, publisher, seq, payload, &tag),
                Verdict::Wrong
            );
        }
        let other = FrameKey::derive(b"another secret");
        assert_eq!(
            other.check("replication:1", 7, 3, b"payload", &tag),
            Verdict::Wrong
        );
        assert_eq!(
            key.check("replication:1", 7, 3, b"payload", &[0; TAG_LEN]),
            Verdict::Untagged
        );
        assert_eq!(format!("{key:?}"), "FrameKey(***)");
    }
}
