//! In-process publish → receive on each backend at 64 B, 4 KiB and 64 KiB.
//!
//! `cargo bench -p seam-bench --bench bench_transport`. One transport publishes, a second one in
//! the same process receives; an iteration is one publish and the receive of that message. The
//! Redis rows need a server at `SEAM_REDIS_URL` (default redis://127.0.0.1:6379) and are left
//! out, with a notice, when none answers.

// criterion_group! generates a public function without docs.
#![allow(missing_docs)]

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use seam_transport::Transport;

fn urls() -> Vec<(&'static str, String)> {
    let prefix = format!("seam_bench_{}_", std::process::id());
    let redis = std::env::var("SEAM_REDIS_URL").unwrap_or("redis://127.0.0.1:6379".into());
    let mut urls = vec![
        ("shm", format!("shm?prefix={prefix}")),
        ("local", format!("local?prefix={prefix}")),
    ];
    match seam_transport::open(&redis) {
        Ok(_) => urls.push(("redis", redis)),
        Err(e) => eprintln!("bench_transport: leaving out redis: {e}"),
    }
    urls
}

fn publish_receive(c: &mut Criterion) {
    let mut group = c.benchmark_group("publish_receive");
    group.measurement_time(Duration::from_secs(3));
    for (name, url) in urls() {
        for size in [64usize, 4096, 65_536] {
            let open = || seam_transport::open(&url).expect("open transport");
            let (mut publisher, mut subscriber): (Box<dyn Transport>, Box<dyn Transport>) =
                (open(), open());
            let channel = format!("bench:{name}:{size}:{}", std::process::id());
            subscriber.subscribe(&channel).expect("subscribe");
            let payload = vec![1u8; size];
            group.throughput(Throughput::Bytes(size as u64));
            group.bench_with_input(BenchmarkId::new(name, size), &size, |b, _| {
                b.iter(|| {
                    publisher.publish(&channel, &payload).expect("publish");
                    let message = subscriber
                        .receive_timeout(Duration::from_secs(5))
                        .expect("receive")
                        .expect("the message arrives");
                    std::hint::black_box(message.payload.len())
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, publish_receive);
criterion_main!(benches);
