//! A forged count or list length cannot make decoding allocate more than the input justifies.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use seam_sim::wire::{self, PhysicsEventsFrame, ReplicationFrame, WIRE_VERSION};

struct Counting;

thread_local! {
    /// Bytes allocated by this thread: the test harness and the other test allocate on other
    /// threads meanwhile, and must not count.
    static ALLOCATED: Cell<usize> = const { Cell::new(0) };
}

fn allocated() -> usize {
    ALLOCATED.with(Cell::get)
}

// SAFETY: forwards every call to the system allocator; only counts bytes on the side.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATED.with(|a| a.set(a.get() + layout.size()));
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

#[test]
fn forged_state_count_allocates_nothing_big() {
    // A replication header claiming u32::MAX exact states, one owner, no specs, and nothing
    // after the owner table.
    let mut bytes = vec![WIRE_VERSION, 0, 1, 0, 0, 0, 0, 0];
    bytes.extend_from_slice(&7u64.to_le_bytes());
    bytes.extend_from_slice(&u32::MAX.to_le_bytes());
    bytes.extend_from_slice(&[0u8; 16]);
    let before = allocated();
    let result = ReplicationFrame::decode(&bytes);
    let allocated = allocated() - before;
    assert!(result.is_err(), "4 billion states from 36 bytes");
    // The error message itself allocates a little; a preallocated list would be gigabytes.
    assert!(
        allocated < 4096,
        "decoding 36 bytes allocated {allocated} bytes"
    );
}

#[test]
fn plausible_length_allocates_in_proportion_to_what_decodes() {
    // An events frame whose op list claims 2000 ops, which the input could back byte for
    // byte (~2000 bytes), but each op takes ~30 bytes, so only a few decode before the input
    // runs out. Preallocating the declared length would take 2000 × size_of::<RoutedOp>().
    let mut bytes = vec![WIRE_VERSION];
    bytes.extend_from_slice(&[0u8; 16]);
    bytes.extend_from_slice(&[0, 0]); // tick 0, published_ns 0
    bytes.extend_from_slice(&[0xD0, 0x0F]); // 2000 as a varint
    bytes.extend(std::iter::repeat_n(0u8, 2000));
    let before = allocated();
    let result = wire::decode::<PhysicsEventsFrame>(&bytes);
    let allocated = allocated() - before;
    assert!(result.is_err(), "the input runs out");
    assert!(
        allocated < 8 * bytes.len(),
        "decoding {} bytes allocated {allocated} bytes",
        bytes.len()
    );
}
