//! A forged list length cannot make decoding allocate more than the input justifies.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use seam_sim::wire::{self, ReplicationFrame, WIRE_VERSION};

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
fn forged_length_allocates_nothing_big() {
    // version, `from` (16 bytes), tick 0, then a list length of u32::MAX and no elements.
    let mut bytes = vec![WIRE_VERSION];
    bytes.extend_from_slice(&[0u8; 16]);
    bytes.push(0);
    bytes.extend_from_slice(&[0xFF, 0xFF, 0xFF, 0xFF, 0x0F]);
    let before = allocated();
    let result = wire::decode::<ReplicationFrame>(&bytes);
    let allocated = allocated() - before;
    assert!(result.is_err(), "4 billion states from 23 bytes");
    // The error message itself allocates a little; a preallocated list would be gigabytes.
    assert!(
        allocated < 4096,
        "decoding 23 bytes allocated {allocated} bytes"
    );
}

#[test]
fn plausible_length_allocates_in_proportion_to_what_decodes() {
    // A length the input could back byte for byte (2000 states in ~2000 bytes), but each state
    // takes ~90 bytes, so only ~20 decode before the input runs out. Preallocating the declared
    // length would take 2000 × size_of::<EntityState>() ≈ 200 KB.
    let mut bytes = vec![WIRE_VERSION];
    bytes.extend_from_slice(&[0u8; 16]);
    bytes.push(0);
    bytes.extend_from_slice(&[0xD0, 0x0F]); // 2000 as a varint
    bytes.extend(std::iter::repeat_n(0u8, 2000));
    let before = allocated();
    let result = wire::decode::<ReplicationFrame>(&bytes);
    let allocated = allocated() - before;
    assert!(result.is_err(), "the input runs out");
    assert!(
        allocated < 8 * bytes.len(),
        "decoding {} bytes allocated {allocated} bytes",
        bytes.len()
    );
}
