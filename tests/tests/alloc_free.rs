//! The steady-state shared-memory path adds no heap allocation to iceoryx2's own.
//!
//! A counting global allocator counts this thread's allocations while a flag is up. After a
//! warm-up (the first publish on a channel creates its ports), receiving must allocate nothing,
//! and publishing must allocate exactly what plain iceoryx2 allocates for the same number of
//! loans, measured in the same run — replication frames included, encoded by a reused
//! `ReplicationEncoder` into the loan and read in place on the other side. iceoryx2 0.10 allocates one small shared-state object per
//! loaned sample (`ChunkMutSharedState::new`); should a later iceoryx2 stop doing so, the
//! baseline drops to zero and so must seam. The in-process backend is held to the same rule.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use seam_sim::wire::{
    BodySpec, ClusterId, EntityId, EntityState, ReplicationEncoder, ReplicationFrame,
    ReplicationView, Shape, StateEncoding,
};
use seam_tests::TestContext;
use seam_transport::{Backend, Transport};

struct CountingAllocator;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: forwards every call to the system allocator unchanged; only counts on the side.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

fn count() {
    // `try_with`: the thread-locals may be gone while a thread shuts down.
    if COUNTING.try_with(Cell::get).unwrap_or(false) {
        let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
    }
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

fn allocations_during(f: impl FnOnce()) -> u64 {
    ALLOCATIONS.with(|n| n.set(0));
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.with(Cell::get)
}

fn steady_state_adds_no_allocation<S: iceoryx2::service::Service>(backend: Backend) {
    let ctx = TestContext::new(backend).expect("iceoryx2 backends are always available");
    let (mut publisher, mut subscriber) = (ctx.open(), ctx.open());
    let channels = [
        ctx.channel("replication:a"),
        ctx.channel("physics_events:a"),
    ];
    for channel in &channels {
        subscriber.subscribe(channel).expect("subscribe");
    }
    // Opaque bytes whose first is no wire version, so the reader below passes over them.
    let frame = [0xeeu8; 512];
    // A replication frame of 64 states as a cluster publishes it: its tables built in a
    // reused encoder, its records written straight into the loaned buffer.
    let owner = ClusterId::from_u128(1);
    let mut replication = ReplicationFrame {
        incarnation: 0,
        from: owner,
        tick: 1,
        states: (0..64u32)
            .map(|i| {
                let body = BodySpec::new(Shape::ball(0.5 + (i % 3) as f32));
                EntityState::new(EntityId::from_u128(u128::from(i) + 1), owner, body)
                    .at([i as f32, 0.0, 0.0])
            })
            .collect(),
    };
    let mut encoder = ReplicationEncoder::default();
    let mut round = |publisher: &mut Box<dyn Transport>| {
        for channel in &channels {
            publisher.publish(channel, &frame).expect("publish");
            publisher
                .publish_with(channel, 256, &mut |buffer| {
                    buffer[..4].copy_from_slice(b"seam");
                    Some(4)
                })
                .expect("publish_with");
        }
        replication.tick += 1;
        for encoding in [StateEncoding::Exact, StateEncoding::Quantized] {
            let len = encoder.prepare(&replication, encoding).expect("encodes");
            publisher
                .publish_with(&channels[0], len, &mut |buffer| {
                    encoder.write(&replication, buffer).ok()
                })
                .expect("publish_with");
        }
    };
    let drain = |subscriber: &mut Box<dyn Transport>| {
        let (mut received, mut states) = (0, 0);
        while let Some(message) = subscriber.try_receive().expect("receive") {
            if let Ok(view) = ReplicationView::parse(message.payload) {
                // Read in place, every record.
                states += view.states().filter(Result::is_ok).count();
            } else {
                assert!(message.payload.len() == 512 || message.payload == b"seam");
            }
            received += 1;
        }
        assert_eq!((received, states), (6, 128));
    };
    for _ in 0..100 {
        round(&mut publisher);
        drain(&mut subscriber);
    }
    const ROUNDS: u64 = 1000;
    let (mut publishing, mut receiving) = (0, 0);
    for _ in 0..ROUNDS {
        publishing += allocations_during(|| round(&mut publisher));
        receiving += allocations_during(|| drain(&mut subscriber));
    }
    assert_eq!(
        receiving,
        0,
        "{backend}: {} receives allocated {receiving} times",
        6 * ROUNDS
    );
    let per_loan = iceoryx2_allocations_per_send::<S>(&ctx);
    assert_eq!(
        publishing,
        6 * ROUNDS * per_loan,
        "{backend}: {} publishes allocated {publishing} times; plain iceoryx2 allocates \
         {per_loan} per send",
        6 * ROUNDS
    );
}

/// Heap allocations of one loan-write-send with a plain iceoryx2 publisher (no seam), the
/// floor a seam publish is held to.
fn iceoryx2_allocations_per_send<S: iceoryx2::service::Service>(ctx: &TestContext) -> u64 {
    use iceoryx2::prelude::*;
    let mut config = iceoryx2::config::Config::default();
    config.global.prefix = FileName::new(b"seam_alloc_floor_").expect("prefix");
    let node = NodeBuilder::new()
        .config(&config)
        .create::<S>()
        .expect("node");
    let name = ServiceName::new(&ctx.channel("floor")).expect("name");
    let service = node
        .service_builder(&name)
        .publish_subscribe::<[u8]>()
        .open_or_create()
        .expect("service");
    let publisher = service
        .publisher_builder()
        .initial_max_slice_len(4096)
        .create()
        .expect("publisher");
    let subscriber = service.subscriber_builder().create().expect("subscriber");
    let send = || {
        let sample = publisher.loan_slice_uninit(512).expect("loan");
        let sample = sample.write_from_fn(|_| 7u8);
        sample.send().expect("send");
        while subscriber.receive().expect("receive").is_some() {}
    };
    for _ in 0..100 {
        send();
    }
    const SENDS: u64 = 1000;
    let total = allocations_during(|| {
        for _ in 0..SENDS {
            send();
        }
    });
    assert_eq!(
        total % SENDS,
        0,
        "plain iceoryx2 allocates a fixed amount per send"
    );
    total / SENDS
}

#[test]
fn shm_steady_state_adds_no_allocation() {
    steady_state_adds_no_allocation::<iceoryx2::service::ipc::Service>(Backend::Shm);
}

#[test]
fn local_steady_state_adds_no_allocation() {
    steady_state_adds_no_allocation::<iceoryx2::service::local::Service>(Backend::Local);
}

#[test]
fn the_counter_sees_allocations() {
    let allocations = allocations_during(|| {
        std::hint::black_box(vec![1u8; 100]);
    });
    assert_eq!(
        allocations, 1,
        "the counting allocator must be able to fail the tests above"
    );
}
