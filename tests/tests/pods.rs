//! The main job end to end: `crossfire`'s two clusters as real pod processes on one host, over
//! shared memory and over Redis, each ticking on its own schedule. Checks that routed ops,
//! contacts and a hand-off crossed between the pods, and that no entity was lost.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use seam_bench::accuracy::{self, AgainstOneWorld, JudgedRun};
use seam_bench::node::AuthorityArgs;
use seam_bench::run::{self, PodSummary, RunPlan, RunReport};
use seam_tests::TestContext;

seam_tests::backend_tests!(
    [shm: Shm, redis: Redis],
    [
        crossfire_pods_cross_the_seam,
        crossfire_pods_scripted_report_contacts,
        signed_crossfire_pods_cross_the_seam
    ]
);

fn scene(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../bench/scenes")
        .join(format!("{name}.toml"))
}

fn plan(scene_name: &str, transport: String, rate: f64, ticks: u64) -> RunPlan {
    RunPlan {
        rate,
        ticks: Some(ticks),
        node_command: vec![env!("CARGO_BIN_EXE_seam-test-node").into()],
        start_delay: Duration::from_millis(500),
        ..RunPlan::new(scene(scene_name), transport)
    }
}

fn run_pods(
    ctx: &TestContext,
    scene_name: &str,
    ticks: u64,
    authority: AuthorityArgs,
    quantize: bool,
) -> RunReport {
    run_judged(ctx, scene_name, ticks, authority, quantize).0
}

/// As [`run_pods`], with the run judged against one world as `seam run` judges it.
fn run_judged(
    ctx: &TestContext,
    scene_name: &str,
    ticks: u64,
    authority: AuthorityArgs,
    quantize: bool,
) -> (RunReport, AgainstOneWorld) {
    // Faster than real time, so the test takes seconds; the scene's events all fall within
    // `ticks`.
    let plan = RunPlan {
        authority,
        quantize,
        track_flips: true,
        ..plan(scene_name, ctx.url(), 300.0, ticks)
    };
    let (report, nodes) = run::run_pods(&plan, &AtomicBool::new(false), |_| {})
        .unwrap_or_else(|e| panic!("seam run {scene_name} on {}: {e}", ctx.url()));
    let against = AgainstOneWorld::judge(&plan, &nodes)
        .unwrap_or_else(|e| panic!("judging {scene_name} against one world: {e}"));
    (report, against)
}

/// The main job with `seam run --sign`: every pod signs with its own cluster's key and checks
/// every frame against the run's keyring, and crossfire holds as unsigned, with every frame
/// taken (none unsigned, none forged, none refused).
fn signed_crossfire_pods_cross_the_seam(ctx: &TestContext) {
    let plan = RunPlan {
        sign: true,
        track_flips: true,
        ..plan("crossfire", ctx.url(), 300.0, 360)
    };
    let (report, nodes) = run::run_pods(&plan, &AtomicBool::new(false), |_| {})
        .unwrap_or_else(|e| panic!("seam run --sign crossfire on {}: {e}", ctx.url()));
    let text = assert_crossfire_holds(&report);
    for node in &nodes {
        assert!(
            node.transport.contains("sign_key=") && node.transport.contains("keyring="),
            "each pod signs and checks: {}",
            node.transport
        );
    }
    for p in &report.pods {
        let t = &p.transport_stats;
        assert_eq!((t.unsigned_drops, t.forged_drops), (0, 0), "{text}");
        assert_eq!(p.cluster_stats.frames_refused(), 0, "{text}");
        assert!(p.cluster_stats.frames_accepted >= 2 * 360, "{text}");
    }
}

fn pod<'a>(report: &'a RunReport, name: &str) -> &'a PodSummary {
    report
        .pods
        .iter()
        .find(|p| p.cluster == name)
        .unwrap_or_else(|| panic!("no pod {name} in the report"))
}

/// What every crossfire run must show: every tick run, no message lost, every routed op applied
/// by its owner (some after being forwarded once by a former owner), every hand-off taken, and
/// every entity owned by exactly one pod at the end.
fn assert_crossfire_holds(report: &RunReport) -> String {
    let text = run::document(report).text();
    let (west, east) = (pod(report, "west"), pod(report, "east"));
    for p in [west, east] {
        assert_eq!(p.ticks, 360, "{} ran every tick\n{text}", p.cluster);
        assert_eq!(p.transport_stats.overflow_drops, 0, "{text}");
        assert_eq!(p.transport_stats.malformed_drops, 0, "{text}");
        assert_eq!(p.cluster_stats.ops_dropped(), 0, "{text}");
        assert_eq!(
            p.cluster_stats.ops_repeated, 0,
            "nothing lost, so nothing sent twice\n{text}"
        );
    }
    // Ops: west's raycast volley and explosion push crates east owns.
    assert!(west.events.writes_routed > 0, "west routed pushes\n{text}");
    let sum = |f: fn(&PodSummary) -> u64| f(west) + f(east);
    let routed = sum(|p| p.cluster_stats.ops_routed);
    let applied = sum(|p| p.cluster_stats.ops_applied);
    assert_eq!(
        applied, routed,
        "every routed op applied by its owner (some forwarded once to it)\n{text}"
    );
    assert_eq!(sum(|p| p.ops.ops), applied, "one timing per op\n{text}");
    assert!(east.ops.transport.p50_ns > 0 && east.ops.whole.p50_ns >= east.ops.transport.p50_ns);
    assert_eq!(
        sum(|p| p.cluster_stats.handoffs_out),
        sum(|p| p.cluster_stats.handoffs_in),
        "every hand-off taken\n{text}"
    );
    // Nothing lost: everything spawned or fired is owned by exactly one pod at the end, each
    // entity checked by id (a count would let one lost and one doubled entity cancel out).
    assert!(report.ownership.holds(), "{:?}\n{text}", report.ownership);
    assert_eq!(
        report.ownership.owned_once, report.ownership.expected,
        "{text}"
    );
    text
}

/// The main job with default settings: authority follows entities, so west's projectile is
/// handed to east as it crosses the seam and hits east's crates in east's own world.
/// The run is judged against one world, beside that world's noise floor: every body the
/// pods ended with is compared, crossfire's volleys hit in both, and the projectile's
/// hand-off is judged.
fn crossfire_pods_cross_the_seam(ctx: &TestContext) {
    let (report, against) = run_judged(ctx, "crossfire", 360, AuthorityArgs::default(), false);
    let text = assert_crossfire_holds(&report);
    let west = pod(&report, "west");
    assert!(
        west.cluster_stats.handoffs_by_policy >= 1,
        "the projectile followed into east\n{text}"
    );
    // Pods in phase exchange their ops before the step: west's pushes on east's crates act
    // on the tick west wrote them (the median one at least, on a loaded machine).
    assert_eq!(
        report.ops.ticks.p50, 0,
        "routed ops applied on their tick\n{text}"
    );
    let judged = accuracy::judged_document(&JudgedRun {
        run: report,
        against_one_world: Some(against.clone()),
    })
    .text();
    let (a, floor) = (&against.accuracy, &against.floor);
    assert!(judged.contains("noise floor"), "{judged}");
    // Crossfire is chaotic: one world perturbed at round-off ends metres from itself.
    assert!(floor.position_rms_m > 0.1, "{judged}");
    assert!(a.position_rms_m.is_finite(), "{judged}");
    assert_eq!(
        a.missing_entity_ticks, 0,
        "every body ended somewhere\n{judged}"
    );
    assert!(a.hits_reference > 0 && a.hits_split > 0, "{judged}");
    assert!(
        a.handoffs >= 1,
        "the projectile's hand-off judged\n{judged}"
    );
    assert_eq!(
        against.beyond_floor.is_empty(),
        judged.contains("at the floor"),
        "{judged}"
    );
}

/// With only the scene's hand-offs, west simulates its projectile all the way, so its strikes
/// on east's crates are contacts with proxies, reported to east; and the scene's hand-off of
/// the runner at tick 300 is refused, counted: friction stopped it 8 m short of the seam,
/// beyond east's region and spread, so east holds no proxy of it to take over. Its pods
/// publish quantized states, which change none of that.
fn crossfire_pods_scripted_report_contacts(ctx: &TestContext) {
    let report = run_pods(ctx, "crossfire", 360, AuthorityArgs::scripted(), true);
    assert!(report.quantize);
    let text = assert_crossfire_holds(&report);
    let (west, east) = (pod(&report, "west"), pod(&report, "east"));
    assert!(
        east.cluster_stats.contacts_received > 0,
        "contacts with east's proxies reached east\n{text}"
    );
    assert!(report.totals.cluster.contacts_received <= report.totals.cluster.contacts_sent);
    assert_eq!(west.events.handoffs, 0, "{text}");
    assert_eq!(
        west.events.refused, 1,
        "the runner's hand-off refused\n{text}"
    );
    assert_eq!(west.cluster_stats.handoffs_out, 0, "{text}");
    assert_eq!(east.cluster_stats.handoffs_in, 0, "{text}");
    assert_eq!(east.entities_owned, east.entities_at_start, "{text}");
}

/// A stop request (what SIGINT or SIGTERM sets in `seam run`) reaches the pods, which stop after
/// their current tick and still report.
#[test]
fn stopping_a_run_stops_the_pods_and_keeps_their_reports() {
    let Some(ctx) = TestContext::new(seam_transport::Backend::Shm) else {
        return;
    };
    let plan = plan("crossfire", ctx.url(), 60.0, 60 * 600);
    let stop = AtomicBool::new(false);
    let started = Instant::now();
    let report = std::thread::scope(|scope| {
        scope.spawn(|| {
            std::thread::sleep(Duration::from_millis(1500));
            stop.store(true, Ordering::Relaxed);
        });
        run::run(&plan, &stop, |_| {}).expect("a stopped run still reports")
    });
    assert!(
        started.elapsed() < Duration::from_secs(30),
        "stopped long before its 600 s"
    );
    for pod in &report.pods {
        assert!(
            pod.ticks > 0 && pod.ticks < 60 * 600,
            "{} stopped early after some ticks: {}",
            pod.cluster,
            pod.ticks
        );
    }
}

/// Pods that cannot start (a Redis server that is not there) make the run fail with their
/// error, promptly, and leave no process behind.
#[test]
fn pods_that_cannot_start_fail_the_run_clearly() {
    let plan = plan("crossfire", "redis://127.0.0.1:1".into(), 60.0, 60);
    let started = Instant::now();
    let error = run::run(&plan, &AtomicBool::new(false), |_| {})
        .expect_err("no server, no run")
        .to_string();
    assert!(
        error.contains("\"west\"") && error.contains("\"east\""),
        "{error}"
    );
    assert!(started.elapsed() < Duration::from_secs(30));
}
