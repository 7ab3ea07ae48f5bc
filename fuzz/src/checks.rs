//! What every fuzz target checks of one input, shared by path with the corpus replay test in
//! `tests/tests/fuzz_corpus.rs` (which runs on stable, in CI, over `fuzz/seeds` and
//! `fuzz/corpus`).

use seam_sim::wire::{self, PhysicsEventsFrame, ReplicationFrame, ReplicationView, StateEncoding};
use seam_transport::Envelope;

/// A received replication frame: checked in place, every record read. Whatever the bytes, no
/// panic; a frame that checks reads as many records as its header says, each a state or an
/// error; a frame that decodes whole encodes back to one that decodes to the same states —
/// bit for bit when exact; quantized, the same entities, owners, ticks and epochs (a decoded
/// rotation is re-normalised before it is quantized again, which may move it a step).
pub(crate) fn replication_frame(bytes: &[u8]) {
    let Ok(view) = ReplicationView::parse(bytes) else {
        return;
    };
    assert_eq!(view.states().count(), view.len());
    for i in 0..view.len() {
        assert!(view.id(i).is_some());
        let _ = view.hands_off(i);
    }
    if let Ok(frame) = ReplicationFrame::decode(bytes) {
        let again = frame
            .encode(view.encoding())
            .expect("a decoded frame encodes");
        let back = ReplicationFrame::decode(&again).expect("what was encoded decodes");
        assert_eq!((back.from, back.tick), (frame.from, frame.tick));
        assert_eq!(back.states.len(), frame.states.len());
        for (a, b) in back.states.iter().zip(&frame.states) {
            assert_eq!(
                (a.id, a.cluster_id, a.tick, a.epoch),
                (b.id, b.cluster_id, b.tick, b.epoch)
            );
            if view.encoding() == StateEncoding::Exact {
                assert_eq!(a.motion_bits(), b.motion_bits());
            }
        }
    }
}

/// A received physics-events frame (postcard): no panic, and a frame that decodes encodes to
/// bytes that decode to a frame encoding the same (compared as bytes: a NaN in an op is not
/// equal to itself).
pub(crate) fn events_frame(bytes: &[u8]) {
    if let Ok(frame) = wire::decode::<PhysicsEventsFrame>(bytes) {
        let again = wire::encode(&frame);
        let back: PhysicsEventsFrame = wire::decode(&again).expect("what was encoded decodes");
        assert_eq!(wire::encode(&back), again);
    }
}

/// The envelope in front of every Redis message: no panic, and a split envelope writes back to
/// the bytes it came from.
pub(crate) fn envelope(bytes: &[u8]) {
    if let Some((envelope, payload)) = Envelope::split(bytes) {
        let mut head = [0u8; Envelope::WIRE_LEN];
        envelope.write_to(&mut head);
        assert_eq!(&head[..], &bytes[..Envelope::WIRE_LEN]);
        assert_eq!(payload, &bytes[Envelope::WIRE_LEN..]);
    }
}

/// Replies on a subscribed Redis connection: see `seam_transport::fuzzing::resp_reader` for
/// what it asserts.
pub(crate) fn resp_reader(bytes: &[u8]) {
    seam_transport::fuzzing::resp_reader(bytes);
}
