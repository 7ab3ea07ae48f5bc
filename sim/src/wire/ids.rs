//! Entity and cluster identities: UUIDs, 16 bytes on the wire.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use uuid::Uuid;

const FNV_OFFSET: u128 = 0x6c62272e07bb014262b821756295c58d;
const FNV_PRIME: u128 = 0x0000000001000000000000000000013b;

/// 128-bit FNV-1a over `parts`, each followed by a separator byte so ("ab", "c") and
/// ("a", "bc") differ.
fn fnv1a(parts: &[&[u8]]) -> u128 {
    let mut hash = FNV_OFFSET;
    for part in parts {
        for &byte in *part {
            hash ^= u128::from(byte);
            hash = hash.wrapping_mul(FNV_PRIME);
        }
        hash ^= 0xff;
        hash = hash.wrapping_mul(FNV_PRIME);
    }
    hash
}

macro_rules! uuid_id {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
        pub struct $name(pub Uuid);

        // One `write_u128`, so `IdHasher` can hash it in a multiply.
        impl std::hash::Hash for $name {
            fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
                state.write_u128(self.0.as_u128());
            }
        }

        impl $name {
            /// The id every process derives from the same `run` and `name`, with no
            /// coordination: a 128-bit FNV-1a hash of both (and of the kind of id, so a
            /// cluster and an entity of one name differ). Pods started separately agree on
            /// it; another `run` shares none. Names are the caller's: "west", "crate#3".
            pub fn named(run: &str, name: &str) -> Self {
                Self::from_u128(fnv1a(&[stringify!($name).as_bytes(), run.as_bytes(), name.as_bytes()]))
            }

            /// A fresh random id.
            pub fn random() -> Self {
                Self(Uuid::new_v4())
            }

            /// The id as a number (Rapier's `user_data` holds entity ids this way).
            pub fn as_u128(self) -> u128 {
                self.0.as_u128()
            }

            /// The id from a number.
            pub fn from_u128(value: u128) -> Self {
                Self(Uuid::from_u128(value))
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                self.0.fmt(f)
            }
        }

        // On the wire: exactly 16 bytes, no length prefix.
        impl Serialize for $name {
            fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                self.0.as_bytes().serialize(serializer)
            }
        }

        impl<'de> Deserialize<'de> for $name {
            fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                <[u8; 16]>::deserialize(deserializer).map(|bytes| Self(Uuid::from_bytes(bytes)))
            }
        }
    };
}

uuid_id!(
    /// A game object. Every body in a cluster's world belongs to exactly one entity.
    EntityId
);
uuid_id!(
    /// One simulation cluster. The cluster an entity's state names is its authority.
    ClusterId
);

impl ClusterId {
    /// The owner of scenery: static level geometry that every cluster loads itself, that no
    /// cluster simulates for another and that is never replicated (the nil UUID; no cluster
    /// has it).
    pub const SCENERY: ClusterId = ClusterId(Uuid::nil());
}

/// A fixed, fast hasher for maps keyed by ids. Ids are UUIDs, random or assigned, so folding the
/// two halves and multiplying spreads them well; being fixed (unseeded), it keeps map iteration
/// order the same from run to run, which determinism needs.
#[derive(Debug, Default, Clone, Copy)]
pub struct IdHasher(u64);

impl std::hash::Hasher for IdHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write_u128(&mut self, value: u128) {
        let folded = (value as u64) ^ ((value >> 64) as u64).rotate_left(29);
        self.0 = (self.0 ^ folded).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        self.0 ^= self.0 >> 32;
    }

    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(16) {
            let mut word = [0u8; 16];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u128(u128::from_le_bytes(word));
        }
    }
}

/// A map keyed by ids, with [`IdHasher`]: entries are stored densely in insertion order behind a
/// small hash index, so a lookup touches little memory and iteration follows the order entities
/// were added (deterministic, and cache-friendly for callers that go in that order).
pub type IdMap<K, V> = indexmap::IndexMap<K, V, std::hash::BuildHasherDefault<IdHasher>>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn named_ids_are_stable_and_distinct() {
        assert_eq!(
            ClusterId::named("run", "west"),
            ClusterId::named("run", "west")
        );
        assert_ne!(
            ClusterId::named("run", "west"),
            ClusterId::named("run", "east")
        );
        assert_ne!(
            ClusterId::named("run", "west"),
            ClusterId::named("other", "west")
        );
        assert_ne!(
            ClusterId::named("run", "ab").as_u128(),
            EntityId::named("run", "ab").as_u128()
        );
        assert_ne!(EntityId::named("a", "bc"), EntityId::named("ab", "c"));
        assert_ne!(ClusterId::named("run", "west"), ClusterId::SCENERY);
    }
}
