//! Where a channel lives in a Redis Cluster: its hash slot (CRC16 of the name, or of its hash
//! tag, modulo 16 384, as the cluster specification defines it) and the primary serving each
//! slot, read from `CLUSTER SLOTS`.

use redis::Value;

/// Slots in a Redis Cluster.
pub(crate) const SLOTS: usize = 16_384;

/// CRC16-CCITT (XMODEM: polynomial 0x1021, initial value 0), the cluster's key hash.
fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    for &byte in bytes {
        crc ^= u16::from(byte) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// The slot of `name`: only its hash tag is hashed when it has one (the text between the first
/// `{` and the first `}` after it, if not empty), so names sharing a tag share a slot.
pub(crate) fn slot_of(name: &str) -> u16 {
    let bytes = name.as_bytes();
    let hashed = bytes
        .iter()
        .position(|&b| b == b'{')
        .and_then(|open| {
            let rest = &bytes[open + 1..];
            rest.iter()
                .position(|&b| b == b'}')
                .filter(|&close| close > 0)
                .map(|close| &rest[..close])
        })
        .unwrap_or(bytes);
    crc16(hashed) % SLOTS as u16
}

/// Which primary (`host:port`) serves each slot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct SlotMap {
    /// The primaries, each once.
    pub(crate) primaries: Vec<String>,
    /// For each slot, its primary's index in `primaries`.
    owner: Vec<u16>,
}

/// Why a `CLUSTER SLOTS` answer is not a usable map.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub(crate) enum SlotsError {
    #[error("the answer to CLUSTER SLOTS is not a list of slot ranges")]
    Shape,
    #[error("slot {0} is served by no primary (the cluster does not cover every slot)")]
    NotCovered(usize),
}

impl Default for SlotMap {
    /// A map of no slots, before the first `CLUSTER SLOTS` (every slot on one unnamed node).
    fn default() -> Self {
        Self {
            primaries: vec![String::new()],
            owner: vec![0; SLOTS],
        }
    }
}

impl SlotMap {
    /// Whether every slot has a named primary (not the default map).
    pub(crate) fn covers_all(&self) -> bool {
        !self.primaries.iter().any(String::is_empty)
    }

    /// The map in a `CLUSTER SLOTS` answer; `asked` is the node it came from (`host`), for a
    /// primary the server names with an empty address (it does not know its own).
    pub(crate) fn from_reply(reply: &Value, asked_host: &str) -> Result<Self, SlotsError> {
        let Value::Array(ranges) = reply else {
            return Err(SlotsError::Shape);
        };
        let mut primaries: Vec<String> = Vec::new();
        let mut owner = vec![u16::MAX; SLOTS];
        for range in ranges {
            let Value::Array(fields) = range else {
                return Err(SlotsError::Shape);
            };
            let (Some(Value::Int(start)), Some(Value::Int(end)), Some(Value::Array(node))) =
                (fields.first(), fields.get(1), fields.get(2))
            else {
                return Err(SlotsError::Shape);
            };
            let host = match node.first() {
                Some(Value::BulkString(host)) if !host.is_empty() => {
                    String::from_utf8_lossy(host).into_owned()
                }
                Some(Value::BulkString(_)) => asked_host.to_owned(),
                _ => return Err(SlotsError::Shape),
            };
            let Some(Value::Int(port)) = node.get(1) else {
                return Err(SlotsError::Shape);
            };
            let addr = format!("{host}:{port}");
            let index = match primaries.iter().position(|p| *p == addr) {
                Some(index) => index,
                None => {
                    primaries.push(addr);
                    primaries.len() - 1
                }
            };
            let (start, end) = (*start as usize, *end as usize);
            if start > end || end >= SLOTS {
                return Err(SlotsError::Shape);
            }
            owner[start..=end].fill(index as u16);
        }
        if let Some(slot) = owner.iter().position(|&o| o == u16::MAX) {
            return Err(SlotsError::NotCovered(slot));
        }
        Ok(Self { primaries, owner })
    }

    /// The primary serving `name`'s slot.
    pub(crate) fn primary_of(&self, name: &str) -> &str {
        &self.primaries[usize::from(self.owner[usize::from(slot_of(name))])]
    }

    /// Notes that `slot` is served by `addr` now (a redirect).
    pub(crate) fn moved(&mut self, slot: u16, addr: &str) {
        let index = match self.primaries.iter().position(|p| p == addr) {
            Some(index) => index,
            None => {
                self.primaries.push(addr.to_owned());
                self.primaries.len() - 1
            }
        };
        self.owner[usize::from(slot)] = index as u16;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_match_the_cluster_specification() {
        // The specification's check value for CRC16-XMODEM, and slots Redis itself gives
        // (`CLUSTER KEYSLOT`).
        assert_eq!(crc16(b"123456789"), 0x31C3);
        assert_eq!(slot_of("foo"), 12_182);
        assert_eq!(slot_of("bar"), 5_061);
        assert_eq!(slot_of("c"), 7_365);
        assert_eq!(slot_of("replication:{0b1c}"), slot_of("0b1c"));
        assert_eq!(
            slot_of("{user1000}.following"),
            slot_of("{user1000}.followers")
        );
        assert_eq!(slot_of("foo{}{bar}"), slot_of("foo{}{bar}"));
        assert_ne!(
            slot_of("foo{}{bar}"),
            slot_of("bar"),
            "an empty tag hashes the whole name"
        );
        assert_eq!(slot_of("foo{{bar}}zap"), slot_of("{bar"));
        assert_eq!(slot_of("foo{bar}{zap}"), slot_of("bar"));
    }

    fn range(start: i64, end: i64, host: &str, port: i64) -> Value {
        Value::Array(vec![
            Value::Int(start),
            Value::Int(end),
            Value::Array(vec![
                Value::BulkString(host.as_bytes().to_vec()),
                Value::Int(port),
            ]),
        ])
    }

    #[test]
    fn a_map_covers_every_slot_or_says_which_is_not() {
        let reply = Value::Array(vec![
            range(0, 5460, "127.0.0.1", 7000),
            range(5461, 10922, "", 7001),
            range(10923, 16383, "127.0.0.1", 7002),
        ]);
        let map = SlotMap::from_reply(&reply, "10.0.0.9").expect("covered");
        assert_eq!(map.primaries.len(), 3);
        assert_eq!(map.primary_of("foo"), "127.0.0.1:7002");
        assert_eq!(map.primary_of("bar"), "127.0.0.1:7000");
        assert_eq!(map.primary_of("c"), "10.0.0.9:7001", "slot 7365");
        let gap = Value::Array(vec![range(0, 5460, "127.0.0.1", 7000)]);
        assert_eq!(
            SlotMap::from_reply(&gap, "h"),
            Err(SlotsError::NotCovered(5461))
        );
        assert_eq!(
            SlotMap::from_reply(&Value::Int(3), "h"),
            Err(SlotsError::Shape)
        );
    }
}
