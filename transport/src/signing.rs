//! Who sent a message: per-cluster ed25519 signatures over every envelope, checked against a
//! keyring, so a receiver knows which signer published a message and drops one nobody it
//! trusts signed.
//!
//! The deployment key of [`crate::auth`] tells a member of the deployment from an outsider;
//! it cannot tell members apart, so anyone holding it can publish as anyone. A signature can:
//! each cluster holds its own signing key, and every receiver holds the keyring of the public
//! keys it trusts, each under its signer's 128-bit identity (in seam, the cluster's id). A
//! signing transport puts its identity and an ed25519 signature in every envelope; a
//! transport with a keyring drops, and counts, a message with no signature
//! (`Stats::unsigned_drops`) or one whose signer it does not know or whose signature is wrong
//! (`Stats::forged_drops`), and hands the rest over with the signer it checked
//! ([`crate::Message::signer`]). Whether that signer may say what the message says is the
//! receiver's to judge (seam's clusters refuse a frame whose claimed sender is not its signer).
//!
//! The signature is over a BLAKE3 digest of the channel name, the envelope's publisher,
//! number, signer and length, and the payload: so a signed message cannot be moved to another
//! channel, renumbered, cut or claimed by another signer. A bridge passes signatures on
//! unchanged, so they hold end to end through it.
//!
//! URL settings (every backend): `sign_key=PATH`, a key file as [`Signer::write_file`] writes
//! it (`seam keys` makes them); `keyring=PATH`, a keyring file as [`Keyring::write_file`]
//! writes it. Files are text: `seam-sign-key v1 ID SEED` and lines of `ID PUBLIC` (hex; `#`
//! starts a comment).

use std::collections::HashMap;
use std::fmt;
use std::path::Path;

use ed25519_dalek::{Signature, Signer as _, SigningKey, VerifyingKey};

use crate::url::SettingError;

/// Bytes of a signature.
pub const SIGNATURE_LEN: usize = 64;

/// A message's signature; all zero when its publisher did not sign.
pub type SignatureBytes = [u8; SIGNATURE_LEN];

/// BLAKE3 key-derivation context of the signed digest (a digest of this kind is never another
/// protocol's).
const CONTEXT: &str = "seam 2026-12 signed envelope v1";

/// First word of a key file.
const KEY_FILE_MAGIC: &str = "seam-sign-key";

/// The digest a signature covers: `payload` published by `publisher` as number `seq` on
/// `channel`, signed by `signer`.
pub fn digest(channel: &str, publisher: u64, seq: u64, signer: u128, payload: &[u8]) -> [u8; 32] {
    let mut hasher = blake3::Hasher::new_derive_key(CONTEXT);
    hasher.update(&(channel.len() as u64).to_le_bytes());
    hasher.update(channel.as_bytes());
    hasher.update(&publisher.to_le_bytes());
    hasher.update(&seq.to_le_bytes());
    hasher.update(&signer.to_le_bytes());
    hasher.update(&(payload.len() as u64).to_le_bytes());
    hasher.update(payload);
    *hasher.finalize().as_bytes()
}

/// One signer's identity and secret key.
#[derive(Clone, PartialEq, Eq)]
pub struct Signer {
    id: u128,
    key: SigningKey,
}

impl fmt::Debug for Signer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Signer({:032x}, ***)", self.id)
    }
}

impl Signer {
    /// A new signer for `id` with a key from the operating system's random source.
    pub fn generate(id: u128) -> std::io::Result<Self> {
        let mut seed = [0u8; 32];
        getrandom::fill(&mut seed)
            .map_err(|e| std::io::Error::other(format!("no random source: {e}")))?;
        Ok(Self::from_seed(id, seed))
    }

    /// The signer for `id` whose secret key is `seed`.
    pub fn from_seed(id: u128, seed: [u8; 32]) -> Self {
        Self {
            id,
            key: SigningKey::from_bytes(&seed),
        }
    }

    /// Its identity.
    pub fn id(&self) -> u128 {
        self.id
    }

    /// Its public key, as a keyring holds it.
    pub fn public(&self) -> [u8; 32] {
        self.key.verifying_key().to_bytes()
    }

    /// The signature of `digest`.
    pub fn sign(&self, digest: &[u8; 32]) -> SignatureBytes {
        self.key.sign(digest).to_bytes()
    }

    /// Writes its key file (readable by its owner only, where the system has modes).
    pub fn write_file(&self, path: &Path) -> std::io::Result<()> {
        let text = format!(
            "{KEY_FILE_MAGIC} v1 {:032x} {}\n",
            self.id,
            hex(&self.key.to_bytes())
        );
        write_private(path, text.as_bytes())
    }

    /// The signer a key file holds.
    pub(crate) fn read_file(path: &str) -> Result<Self, SettingError> {
        let bad = |reason: String| SettingError::SignKey {
            path: path.to_owned(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
        let words: Vec<&str> = text.split_whitespace().collect();
        match words.as_slice() {
            [KEY_FILE_MAGIC, "v1", id, seed] => Ok(Self::from_seed(
                parse_id(id).ok_or_else(|| bad(format!("bad identity {id:?}")))?,
                unhex::<32>(seed).ok_or_else(|| bad("the key is not 64 hex digits".to_owned()))?,
            )),
            _ => Err(bad(format!(
                "not a seam key file (expected `{KEY_FILE_MAGIC} v1 ID KEY`)"
            ))),
        }
    }
}

/// The public keys a receiver trusts, each under its signer's identity.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Keyring {
    keys: HashMap<u128, VerifyingKey>,
}

/// What checking a message's signature found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SignVerdict {
    /// Signed by the signer it names, unchanged.
    Good,
    /// Not signed.
    Unsigned,
    /// A signer the keyring does not hold, or a signature that does not check out.
    Forged,
}

impl Keyring {
    /// A keyring of `signers`' public keys.
    pub fn of<'a>(signers: impl IntoIterator<Item = &'a Signer>) -> Self {
        Self {
            keys: signers
                .into_iter()
                .map(|s| (s.id, s.key.verifying_key()))
                .collect(),
        }
    }

    /// How many signers it holds.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Checks `signature` of `digest` by `signer`.
    pub fn check(
        &self,
        signer: u128,
        digest: &[u8; 32],
        signature: &SignatureBytes,
    ) -> SignVerdict {
        if signature == &[0u8; SIGNATURE_LEN] {
            return SignVerdict::Unsigned;
        }
        match self.keys.get(&signer) {
            Some(key)
                if key
                    .verify_strict(digest, &Signature::from_bytes(signature))
                    .is_ok() =>
            {
                SignVerdict::Good
            }
            _ => SignVerdict::Forged,
        }
    }

    /// Writes it as a keyring file.
    pub fn write_file(&self, path: &Path) -> std::io::Result<()> {
        let mut ids: Vec<_> = self.keys.keys().copied().collect();
        ids.sort_unstable();
        let mut text = String::from("# seam keyring: signer identity, ed25519 public key\n");
        for id in ids {
            text.push_str(&format!("{id:032x} {}\n", hex(&self.keys[&id].to_bytes())));
        }
        std::fs::write(path, text)
    }

    /// The keyring a keyring file holds.
    pub(crate) fn read_file(path: &str) -> Result<Self, SettingError> {
        let text = std::fs::read_to_string(path).map_err(|e| SettingError::Keyring {
            path: path.to_owned(),
            reason: e.to_string(),
        })?;
        let mut keys = HashMap::new();
        for (number, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let bad = |reason: &str| SettingError::Keyring {
                path: path.to_owned(),
                reason: format!("line {}: {reason}", number + 1),
            };
            let mut words = line.split_whitespace();
            let (Some(id), Some(public), None) = (words.next(), words.next(), words.next()) else {
                return Err(bad("expected `ID PUBLIC`"));
            };
            let id = parse_id(id).ok_or_else(|| bad("bad identity"))?;
            let key = unhex::<32>(public)
                .and_then(|bytes| VerifyingKey::from_bytes(&bytes).ok())
                .ok_or_else(|| bad("not an ed25519 public key"))?;
            keys.insert(id, key);
        }
        if keys.is_empty() {
            return Err(SettingError::Keyring {
                path: path.to_owned(),
                reason: "it holds no key".to_owned(),
            });
        }
        Ok(Self { keys })
    }
}

/// Makes a signer for each `(identity, name)` of `signers`, writes its key file `DIR/NAME.key`
/// (its owner's only) and the keyring `DIR/keyring` of them all; returns each one's URL
/// settings (`sign_key=…&keyring=…`), in order. `dir` must exist.
pub fn write_keys(dir: &Path, signers: &[(u128, String)]) -> std::io::Result<Vec<String>> {
    let at = |path: &Path, e: std::io::Error| {
        std::io::Error::new(e.kind(), format!("{}: {e}", path.display()))
    };
    let keyring = dir.join("keyring");
    let mut made = Vec::with_capacity(signers.len());
    let mut settings = Vec::with_capacity(signers.len());
    for (id, name) in signers {
        let signer = Signer::generate(*id)?;
        let path = dir.join(format!("{name}.key"));
        signer.write_file(&path).map_err(|e| at(&path, e))?;
        settings.push(format!(
            "sign_key={}&keyring={}",
            path.display(),
            keyring.display()
        ));
        made.push(signer);
    }
    Keyring::of(&made)
        .write_file(&keyring)
        .map_err(|e| at(&keyring, e))?;
    Ok(settings)
}

/// A transport's signing settings: its own signer and the keyring it checks with.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Signing {
    /// Signs every message this transport publishes (`sign_key=`).
    pub signer: Option<Signer>,
    /// Checks every message it receives (`keyring=`).
    pub keyring: Option<Keyring>,
}

impl Signing {
    /// Applies a URL setting if it is one of signing's (`sign_key`, `keyring`); `None` for
    /// another setting.
    pub(crate) fn set(&mut self, key: &str, value: &str) -> Option<Result<(), SettingError>> {
        match key {
            "sign_key" => Some(Signer::read_file(value).map(|s| self.signer = Some(s))),
            "keyring" => Some(Keyring::read_file(value).map(|k| self.keyring = Some(k))),
            _ => None,
        }
    }
}

fn parse_id(text: &str) -> Option<u128> {
    (text.len() == 32)
        .then(|| u128::from_str_radix(text, 16).ok())
        .flatten()
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex<const N: usize>(text: &str) -> Option<[u8; N]> {
    if text.len() != 2 * N || !text.is_ascii() {
        return None;
    }
    let mut out = [0u8; N];
    for (i, byte) in out.iter_mut().enumerate() {
        *byte = u8::from_str_radix(&text[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(out)
}

#[cfg(unix)]
fn write_private(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(path)?;
    file.write_all(bytes)
}

#[cfg(not(unix))]
fn write_private(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    std::fs::write(path, bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_signature_binds_signer_channel_numbering_and_payload() {
        let (west, east) = (Signer::from_seed(1, [7; 32]), Signer::from_seed(2, [9; 32]));
        let ring = Keyring::of([&west, &east]);
        let good = digest("replication:{w}", 5, 3, 1, b"payload");
        let signature = west.sign(&good);
        assert_eq!(ring.check(1, &good, &signature), SignVerdict::Good);
        assert_eq!(
            ring.check(2, &good, &signature),
            SignVerdict::Forged,
            "east"
        );
        assert_eq!(
            ring.check(3, &good, &signature),
            SignVerdict::Forged,
            "unknown"
        );
        assert_eq!(ring.check(1, &good, &[0; 64]), SignVerdict::Unsigned);
        for changed in [
            digest("replication:{e}", 5, 3, 1, b"payload"),
            digest("replication:{w}", 6, 3, 1, b"payload"),
            digest("replication:{w}", 5, 4, 1, b"payload"),
            digest("replication:{w}", 5, 3, 2, b"payload"),
            digest("replication:{w}", 5, 3, 1, b"paylo"),
        ] {
            assert_eq!(ring.check(1, &changed, &signature), SignVerdict::Forged);
        }
        assert_eq!(format!("{west:?}"), format!("Signer({:032x}, ***)", 1));
    }

    #[test]
    fn key_files_and_keyrings_read_back_and_refuse_garbage() {
        let dir = std::env::temp_dir().join(format!("seam-signing-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let signer = Signer::generate(0xabc).expect("random");
        let (key, ring) = (dir.join("west.key"), dir.join("keyring"));
        signer.write_file(&key).expect("key file");
        Keyring::of([&signer]).write_file(&ring).expect("keyring");
        let read = Signer::read_file(key.to_str().expect("utf-8")).expect("reads");
        assert_eq!(read, signer);
        let ring = Keyring::read_file(ring.to_str().expect("utf-8")).expect("reads");
        assert_eq!(ring, Keyring::of([&signer]));
        let garbage = dir.join("garbage");
        std::fs::write(&garbage, "seam-sign-key v1 zz 00\n").expect("write");
        let garbage = garbage.to_str().expect("utf-8");
        assert!(Signer::read_file(garbage).is_err());
        assert!(Keyring::read_file(garbage).is_err());
        assert!(Keyring::read_file("/nonexistent/keyring").is_err());
        std::fs::remove_dir_all(&dir).expect("clean up");
    }
}
