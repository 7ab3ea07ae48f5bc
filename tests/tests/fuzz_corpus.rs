//! Replays every input kept for the fuzz targets (`fuzz/seeds`, the hand-made starting points,
//! and `fuzz/corpus`, what `cargo fuzz` found and minimised) through the same checks, on
//! stable: a decoder change that panics or breaks a round trip on any of them fails here
//! without a fuzzer.

use std::path::Path;

#[path = "../../fuzz/src/checks.rs"]
mod checks;

fn replay(target: &str, check: fn(&[u8])) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz");
    let mut inputs = 0;
    for kept in ["seeds", "corpus"] {
        let Ok(dir) = std::fs::read_dir(root.join(kept).join(target)) else {
            continue;
        };
        for entry in dir {
            let path = entry.expect("a directory entry").path();
            let bytes = std::fs::read(&path).expect("readable input");
            let result = std::panic::catch_unwind(|| check(&bytes));
            assert!(
                result.is_ok(),
                "{target}: {} fails its check",
                path.display()
            );
            inputs += 1;
        }
    }
    assert!(inputs > 0, "no inputs kept for {target}");
}

#[test]
fn replication_frame_inputs_pass() {
    replay("replication_frame", checks::replication_frame);
}

/// The hand-made seeds start the fuzzer on both kinds of replication frame.
#[test]
fn the_seeds_hold_whole_and_delta_frames() {
    let dir =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/replication_frame");
    let kinds: Vec<bool> = std::fs::read_dir(dir)
        .expect("the seeds")
        .filter_map(|entry| std::fs::read(entry.ok()?.path()).ok())
        .filter_map(|bytes| {
            seam_sim::wire::ReplicationView::parse(&bytes)
                .ok()
                .map(|view| view.delta().is_some())
        })
        .collect();
    assert!(kinds.contains(&true) && kinds.contains(&false), "{kinds:?}");
}

/// A seed starts the envelope fuzzer on the current envelope version, tag and signature
/// included: the tag made with the key of `fuzz-seed-secret`, the signature by the signer
/// 0x5eed whose secret key is 32 bytes of 7, both on `replication:{seed}`.
#[test]
fn an_envelope_seed_is_a_current_tagged_signed_envelope() {
    use seam_transport::signing::{Keyring, SignVerdict, Signer, digest};
    let bytes = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fuzz/seeds/envelope/tagged_signed_v3"),
    )
    .expect("the seed");
    let (envelope, payload) =
        seam_transport::Envelope::split(&bytes).expect("the seed is a valid envelope");
    assert_eq!(envelope.version, seam_transport::ENVELOPE_VERSION);
    assert_eq!(payload, b"frame bytes");
    let channel = "replication:{seed}";
    let key = seam_transport::auth::FrameKey::derive(b"fuzz-seed-secret");
    let (publisher, seq) = (envelope.publisher, envelope.seq);
    assert_eq!(
        key.check(channel, publisher, seq, payload, &envelope.tag),
        seam_transport::auth::Verdict::Good
    );
    let signer = u128::from_le_bytes(envelope.signer);
    let ring = Keyring::of([&Signer::from_seed(0x5eed, [7; 32])]);
    assert_eq!(
        ring.check(
            signer,
            &digest(channel, publisher, seq, signer, payload),
            &envelope.signature
        ),
        SignVerdict::Good
    );
}

/// Every hand-made events seed is a frame of the current wire version, and one is an
/// exchange frame (before the step) carrying a write on the sender's own body.
#[test]
fn the_events_seeds_are_current_frames() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/events_frame");
    let mut exchange = 0;
    for entry in std::fs::read_dir(dir).expect("the seeds") {
        let path = entry.expect("a directory entry").path();
        let bytes = std::fs::read(&path).expect("readable seed");
        let frame: seam_sim::wire::PhysicsEventsFrame = seam_sim::wire::decode(&bytes)
            .unwrap_or_else(|e| panic!("{} is not a current frame: {e}", path.display()));
        if frame.stage == seam_sim::wire::Stage::BeforeStep && !frame.own_writes.is_empty() {
            exchange += 1;
        }
    }
    assert_eq!(
        exchange, 1,
        "one seed is an exchange frame with an own write"
    );
}

#[test]
fn events_frame_inputs_pass() {
    replay("events_frame", checks::events_frame);
}

#[test]
fn envelope_inputs_pass() {
    replay("envelope", checks::envelope);
}

#[test]
fn resp_reader_inputs_pass() {
    replay("resp_reader", checks::resp_reader);
}
