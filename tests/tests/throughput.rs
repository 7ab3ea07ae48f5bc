//! `seam throughput` end to end, short: a private server and a private Redis Cluster of three
//! primaries each carry a small load, and the rows agree with themselves. Speeds are the
//! benchmark's (BENCHMARKS.md), not this test's. Without `redis-server` this skips, or fails
//! under `SEAM_REQUIRE_REDIS=1`.

use std::time::Duration;

use seam_bench::throughput::{self, Target, ThroughputPlan};

#[test]
fn throughput_carries_a_small_load_on_a_server_and_a_cluster() {
    // Only to see whether a private cluster can be made here.
    if seam_tests::private_cluster().is_none() {
        return;
    }
    let plan = ThroughputPlan {
        targets: vec![Target::Server, Target::Cluster(3)],
        rates: vec![1_000],
        window: Duration::from_millis(800),
        channels: 12,
        publishers: 1,
        subscribers: 2,
        size: 64,
    };
    let rows = throughput::run(&plan, |_| {}).expect("seam throughput runs");
    let table = throughput::document(&rows).text();
    assert_eq!(rows.len(), 2, "{table}");
    assert_eq!(
        rows.iter().map(|r| r.nodes).collect::<Vec<_>>(),
        [1, 3],
        "{table}"
    );
    for row in &rows {
        // 1 000 a second is far below any saturation: published at the pace, all delivered.
        assert!(row.published_per_s > 800.0, "{table}");
        assert!(
            row.delivered_per_s <= row.published_per_s * 1.01 && !row.saturated,
            "{table}"
        );
        assert!(row.busiest_node_cpu_pct >= row.mean_node_cpu_pct, "{table}");
    }
    assert!(table.contains("carried"), "{table}");
}
