//! `seam chaos` end to end, short: crossfire pods over shared memory and over a private Redis
//! server (with a frame key), killed and restarted, stopped and continued, the server
//! restarted, garbage and forged frames in every channel — and every target holds.

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use seam_bench::chaos::{self, Broker, ChaosPlan, ChaosReport};
use seam_bench::record::{Chunk, PartsDir, Recording};
use seam_tests::{private_redis, scene_path};

fn chaos_run(broker: Broker, key: Option<&str>) -> ChaosReport {
    chaos_run_recorded(broker, key, None)
}

fn chaos_run_recorded(
    broker: Broker,
    key: Option<&str>,
    record_dir: Option<std::path::PathBuf>,
) -> ChaosReport {
    let plan = ChaosPlan {
        scene: scene_path("crossfire.toml"),
        broker,
        rate: 60.0,
        // Four kinds of fault take turns on a Redis Cluster: a longer run to fit them all.
        duration: Duration::from_secs(if broker == Broker::RedisCluster {
            32
        } else {
            20
        }),
        fault_every: Duration::from_secs(2),
        layers: 1,
        seed: 7,
        node_command: vec![env!("CARGO_BIN_EXE_seam-test-node").into()],
        key: key.map(str::to_owned),
        record_dir,
    };
    chaos::run(&plan, &AtomicBool::new(false), |_| {}).expect("seam chaos runs")
}

fn assert_held(report: &ChaosReport) {
    let table = chaos::document(report).text();
    assert!(report.holds(), "{table}");
    assert!(
        report.faults.kill >= 1 && report.faults.stop >= 1,
        "{table}"
    );
    assert!(report.injected.garbage_deliveries > 0, "{table}");
    assert!(report.injected.forged_deliveries > 0, "{table}");
    assert!(report.recovery.entities_adopted > 0, "{table}");
    // The pods' ledgers were written and followed: every routed op is named in them.
    assert!(report.ops.routed > 0, "{table}");
    assert!(report.by_name.ops.sent >= report.ops.routed, "{table}");
    assert!(report.by_name.ops.ended_once > 0, "{table}");
}

#[test]
fn chaos_on_shared_memory_loses_nothing() {
    // Recorded: every incarnation of every pod writes its own part, and the faults go in too.
    let out = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("chaos-shm.rec");
    let parts = PartsDir::beside(Some(&out)).expect("parts folder");
    let report = chaos_run_recorded(Broker::Shm, None, Some(parts.dir.clone()));
    assert_held(&report);
    let summary = parts
        .merge_into(&out, &report.fault_log, "seam chaos")
        .expect("the parts merge");
    // Two pods, and a part for each restart of a killed one.
    assert_eq!(summary.parts as u64, 2 + report.faults.kill, "{summary:?}");
    let recording = Recording::read(&out).expect("the recording reads back");
    let faults: Vec<&str> = recording
        .chunks
        .iter()
        .filter_map(|c| match c {
            Chunk::Fault(f) => Some(f.what.as_str()),
            Chunk::Tick(_) => None,
        })
        .collect();
    let kills = faults.iter().filter(|f| f.ends_with("killed")).count() as u64;
    let stops = faults.iter().filter(|f| f.ends_with("stopped")).count() as u64;
    assert_eq!(
        (kills, stops),
        (report.faults.kill, report.faults.stop),
        "{faults:?}"
    );
    // Both pods' streams run to the end of the run.
    for stream in 0..2u16 {
        assert!(
            recording.stream_ticks(stream).count() > 600,
            "stream {stream}"
        );
    }
}

#[test]
fn chaos_on_redis_loses_nothing() {
    // Only to see whether a private server can start here.
    if private_redis().is_none() {
        return;
    }
    // With a frame key: everything the injector (which has none) sends is dropped as untagged
    // before a decoder sees it (`ChaosReport::accounted`).
    let report = chaos_run(Broker::Redis, Some("chaos-key"));
    assert!(report.keyed);
    assert_held(&report);
    assert_eq!(
        report.frames.untagged,
        report.injected.garbage_deliveries + report.injected.forged_deliveries
    );
    assert!(
        report.faults.redis_restart >= 1,
        "{}",
        chaos::document(&report).text()
    );
    assert!(report.recovery.reconnects >= 1);
}

#[test]
fn chaos_on_a_redis_cluster_loses_nothing() {
    // Only to see whether a private cluster can be made here.
    if seam_tests::private_cluster().is_none() {
        return;
    }
    let report = chaos_run(Broker::RedisCluster, None);
    assert_held(&report);
    let table = chaos::document(&report).text();
    assert!(
        report.faults.primary_kill >= 1 && report.faults.slot_move >= 1,
        "a primary killed and a slot moved: {table}"
    );
    assert!(report.transport.starts_with("redis-cluster://"), "{table}");
}
