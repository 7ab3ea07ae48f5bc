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
    /// Messages dropped by a transport with a keyring because they were not signed.
    pub unsigned_drops: u64,
    /// Messages dropped by a transport with a keyring because no signer it trusts signed them
    /// as they are (an unknown signer, another signer's key, or changed on the way).
    pub forged_drops: u64,
    /// Redis Cluster: channels subscribed again at another node after the server dropped them
    /// (their slot moved, or its primary changed).
    pub resubscribes: u64,
    /// Redis Cluster: publishes the server redirected (`MOVED`/`ASK`) and sent again where
    /// its slot lives now.
    pub redirects: u64,
}

impl Stats {
    /// Adds `other`'s counts to these (a transport made of several, as on a Redis Cluster).
    pub fn add(&mut self, other: &Stats) {
        let Stats {
            published,
            received,
            overflow_drops,
            malformed_drops,
            disconnects,
            reconnects,
            down_ns,
            dropped_while_down,
            untagged_drops,
            bad_tag_drops,
            unsigned_drops,
            forged_drops,
            resubscribes,
            redirects,
        } = *other;
        self.published += published;
        self.received += received;
        self.overflow_drops += overflow_drops;
        self.malformed_drops += malformed_drops;
        self.disconnects += disconnects;
        self.reconnects += reconnects;
        self.down_ns += down_ns;
        self.dropped_while_down += dropped_while_down;
        self.untagged_drops += untagged_drops;
        self.bad_tag_drops += bad_tag_drops;
        self.unsigned_drops += unsigned_drops;
        self.forged_drops += forged_drops;
        self.resubscribes += resubscribes;
        self.redirects += redirects;
    }
}
