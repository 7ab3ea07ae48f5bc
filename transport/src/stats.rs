//! Counters every transport keeps.

/// What a transport has done since it was opened. Drops are counted on the receiving side.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Messages published.
    pub published: u64,
    /// Messages handed to the caller by a receive.
    pub received: u64,
    /// Messages a publisher sent that never reached this receiver because its receive buffer was
    /// full (found as gaps in the per-publisher sequence numbers, counted from the first message
    /// received from each publisher on each channel).
    pub overflow_drops: u64,
    /// Messages that were not seam envelopes (foreign or corrupted bytes on a channel), skipped.
    pub malformed_drops: u64,
    /// Times the connection to a server was lost (Redis; see its reconnect).
    pub disconnects: u64,
    /// Times it was re-established.
    pub reconnects: u64,
    /// Time spent disconnected, ns (the current outage included).
    pub down_ns: u64,
    /// Publishes dropped because the server was unreachable.
    pub dropped_while_down: u64,
    /// Messages dropped by a transport with a frame key because they carried no tag (their
    /// publisher had no key).
    pub untagged_drops: u64,
    /// Messages dropped by a transport with a frame key because their tag was wrong (another
    /// key, or changed on the way).
    pub bad_tag_drops: u64,
}
