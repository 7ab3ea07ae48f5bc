//! Channel names: the one rule every backend enforces.
//!
//! A channel name is 1 to [`MAX_CHANNEL_LEN`] bytes of printable ASCII (`!` to `~`). Redis would
//! take any bytes, but iceoryx2 service names are at most 255 bytes and seam wants one rule on
//! every backend, so a game that runs on Redis today runs on shared memory tomorrow.

use crate::error::{ChannelError, PublishError};

/// The longest channel name, in bytes; iceoryx2's limit for a service name.
pub const MAX_CHANNEL_LEN: usize = 255;

/// What every backend checks before it publishes: a channel name the common rule allows, and
/// a payload (or the room asked for one) of at most `max` bytes.
pub(crate) fn check_publish(channel: &str, len: usize, max: usize) -> Result<(), PublishError> {
    validate_channel(channel)?;
    if len > max {
        return Err(PublishError::PayloadTooLarge { len, max });
    }
    Ok(())
}

/// Checks a channel name (or a pattern, which obeys the same rule) against the common rule.
pub fn validate_channel(name: &str) -> Result<(), ChannelError> {
    if name.is_empty() {
        return Err(ChannelError::Empty);
    }
    if name.len() > MAX_CHANNEL_LEN {
        return Err(ChannelError::TooLong {
            len: name.len(),
            max: MAX_CHANNEL_LEN,
        });
    }
    if let Some(position) = name.bytes().position(|b| !b.is_ascii_graphic()) {
        return Err(ChannelError::NotPrintableAscii { position });
    }
    // iceoryx2 reserves this prefix for its own services.
    if name.starts_with("iox2://") {
        return Err(ChannelError::Reserved);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accepts_seam_channels() {
        assert_eq!(validate_channel("replication:0b1c"), Ok(()));
        assert_eq!(validate_channel("physics_events:*"), Ok(()));
        assert_eq!(validate_channel(&"x".repeat(MAX_CHANNEL_LEN)), Ok(()));
    }

    #[test]
    fn rejects_bad_names() {
        assert_eq!(validate_channel(""), Err(ChannelError::Empty));
        assert_eq!(
            validate_channel(&"x".repeat(256)),
            Err(ChannelError::TooLong { len: 256, max: 255 })
        );
        assert_eq!(
            validate_channel("a b"),
            Err(ChannelError::NotPrintableAscii { position: 1 })
        );
        assert_eq!(
            validate_channel("kanal:ü"),
            Err(ChannelError::NotPrintableAscii { position: 6 })
        );
        assert_eq!(validate_channel("iox2://x"), Err(ChannelError::Reserved));
    }
}
