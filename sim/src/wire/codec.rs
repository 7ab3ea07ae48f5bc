//! Frames as bytes: postcard behind the version byte, safe on untrusted input.

use serde::de::{DeserializeOwned, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};

use super::WIRE_VERSION;

/// Why bytes are not a frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum WireError {
    /// No bytes at all.
    #[error("empty frame")]
    Empty,
    /// The frame is of another format version.
    #[error("frame format version {found}, this build reads version {WIRE_VERSION}")]
    Version {
        /// The version byte found.
        found: u8,
    },
    /// The body does not decode.
    #[error("malformed frame: {0}")]
    Malformed(String),
    /// The body decodes but bytes are left over.
    #[error("{0} bytes after the end of the frame")]
    TrailingBytes(usize),
    /// The destination buffer is too small.
    #[error("frame needs {needed} bytes, the buffer has {capacity}")]
    BufferTooSmall {
        /// Encoded size.
        needed: usize,
        /// Buffer size.
        capacity: usize,
    },
}

/// Deserializes a list by pushing elements as they decode: a declared length that the input
/// cannot back is never used to preallocate.
pub(super) fn grow_as_decoded<'de, D, T>(deserializer: D) -> Result<Vec<T>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct Grow<T>(std::marker::PhantomData<T>);
    impl<'de, T: Deserialize<'de>> Visitor<'de> for Grow<T> {
        type Value = Vec<T>;
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("a list")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
            let mut items = Vec::new();
            while let Some(item) = seq.next_element()? {
                items.push(item);
            }
            Ok(items)
        }
    }
    deserializer.deserialize_seq(Grow(std::marker::PhantomData))
}

/// Encoded size of `frame` in bytes, version byte included.
pub fn encoded_len<T: Serialize>(frame: &T) -> usize {
    1 + postcard::serialize_with_flavor(frame, postcard::ser_flavors::Size::default()).unwrap_or(0)
}

/// Encodes `frame` into the start of `buffer` (for example a loaned shared-memory sample);
/// returns the bytes written. The frame is walked once; its size is worked out only when it
/// does not fit.
pub fn encode_into<T: Serialize>(frame: &T, buffer: &mut [u8]) -> Result<usize, WireError> {
    let too_small = |buffer: &[u8]| WireError::BufferTooSmall {
        needed: encoded_len(frame),
        capacity: buffer.len(),
    };
    let Some((version, rest)) = buffer.split_first_mut() else {
        return Err(too_small(buffer));
    };
    *version = WIRE_VERSION;
    match postcard::to_slice(frame, rest) {
        Ok(body) => Ok(1 + body.len()),
        Err(postcard::Error::SerializeBufferFull) => Err(too_small(buffer)),
        Err(e) => Err(WireError::Malformed(e.to_string())),
    }
}

/// Encodes `frame` into a new buffer.
pub fn encode<T: Serialize>(frame: &T) -> Vec<u8> {
    let mut buffer = vec![0; encoded_len(frame)];
    let written = encode_into(frame, &mut buffer).unwrap_or(0);
    buffer.truncate(written);
    buffer
}

/// Decodes a frame from untrusted bytes.
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, WireError> {
    let (&version, body) = bytes.split_first().ok_or(WireError::Empty)?;
    if version != WIRE_VERSION {
        return Err(WireError::Version { found: version });
    }
    let (frame, rest) =
        postcard::take_from_bytes(body).map_err(|e| WireError::Malformed(e.to_string()))?;
    if !rest.is_empty() {
        return Err(WireError::TrailingBytes(rest.len()));
    }
    Ok(frame)
}
