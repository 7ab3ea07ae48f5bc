//! Pods on several hosts: shared memory inside a host, one `seam bridge` per host carrying what
//! crosses hosts over a real Redis server. Each simulated host is its own iceoryx2 prefix, so a
//! frame reaches a pod of another host only through the two bridges and Redis.

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use seam_bench::bridge::{BridgeLine, host_url};
use seam_bench::node::NodeReport;
use seam_bench::relay::Delay;
use seam_bench::run::{self, HostsPlan, PodSummary, RunPlan, RunReport};
use seam_proxy::monotonic_ns;
use seam_tests::{TestContext, finish_pod, redis_url, scene_path, start_pod};
use seam_transport::Backend;

const NODE: &str = env!("CARGO_BIN_EXE_seam-test-node");

/// A run of `scene` on `hosts` simulated hosts, each pod on its host's own shared memory under
/// this test's prefix, or `None` where Redis is not there (and not required).
fn plan(scene: &str, hosts: u32, rate: f64, ticks: u64) -> Option<RunPlan> {
    let ctx = TestContext::new(Backend::Redis)?;
    let shm = TestContext::new(Backend::Shm)?;
    drop(ctx);
    Some(RunPlan {
        rate,
        ticks: Some(ticks),
        node_command: vec![NODE.into()],
        start_delay: Duration::from_millis(500),
        hosts: HostsPlan {
            count: Some(hosts),
            redis: redis_url(),
            ..HostsPlan::default()
        },
        ..RunPlan::new(scene_path(scene), shm.url())
    })
}

fn pod<'a>(report: &'a RunReport, name: &str) -> &'a PodSummary {
    report
        .pods
        .iter()
        .find(|p| p.cluster == name)
        .unwrap_or_else(|| panic!("no pod {name} in the report"))
}

/// Checks what every run on several hosts must show: each host's bridge carried messages both
/// ways and refused none, no pod lost or refused a message, and every entity ended with one
/// owner.
fn assert_hosts_hold(report: &RunReport) -> String {
    let text = run::document(report).text();
    let hosts = report
        .hosts
        .as_ref()
        .expect("a run on two hosts reports them");
    assert_eq!(hosts.bridges.len(), 2, "{text}");
    // Network namespaces where they can be made (root), and otherwise a report that says
    // what the hosts were instead, and why.
    let namespaces = hosts.simulated_as.starts_with("network namespaces");
    assert!(
        namespaces || hosts.simulated_as.starts_with(run::SIMULATED_AS),
        "{}",
        hosts.simulated_as
    );
    if !rustix::process::geteuid().is_root() {
        assert!(!namespaces && hosts.simulated_as.ends_with("not root"));
    }
    for bridge in &hosts.bridges {
        assert!(
            bridge.out.messages > 0 && bridge.into.messages > 0,
            "{text}"
        );
        assert_eq!(bridge.out.refused + bridge.into.refused, 0, "{text}");
    }
    for p in &report.pods {
        assert_eq!(p.transport_stats.malformed_drops, 0, "{text}");
        assert_eq!(
            p.transport_stats.overflow_drops, 0,
            "nothing lost on the way (gaps in the publishers' numbering, end to end)\n{text}"
        );
        assert_eq!(
            p.cluster_stats.neighbours_lost, 0,
            "nobody taken for dead\n{text}"
        );
    }
    assert!(report.ownership.holds(), "{:?}\n{text}", report.ownership);
    text
}

/// `crossfire`'s two clusters on two hosts: every routed op, contact and hand-off between them
/// crosses the host boundary, through both bridges and Redis, and arrives.
#[test]
fn crossfire_on_two_hosts_crosses_through_the_bridges() {
    crossfire_on_two_hosts(Delay::NONE);
}

/// The same with host b 20 ms from Redis each way (a relay delays its traffic): the bridges
/// keep up — a bridge that waited for each publish's reply would pass on 25 messages a second
/// and drop the rest.
#[test]
fn crossfire_on_two_hosts_20_ms_apart_loses_nothing() {
    crossfire_on_two_hosts(Delay {
        base: Duration::from_millis(20),
        jitter: Duration::from_millis(2),
    });
}

fn crossfire_on_two_hosts(delay: Delay) {
    // crossfire with its runner's hand-off going (`variants/crossfire-handoff`): east then owns
    // a body on west's ground, so contact reports cross hosts too.
    let Some(mut plan) = plan("variants/crossfire-handoff.toml", 2, 120.0, 360) else {
        return;
    };
    plan.hosts.delay = delay;
    let report = run::run(&plan, &AtomicBool::new(false), |_| {})
        .unwrap_or_else(|e| panic!("crossfire on two hosts: {e}"));
    let text = assert_hosts_hold(&report);
    let hosts = report.hosts.as_ref().expect("hosts");
    assert_eq!(hosts.layout, ["a", "b"], "west on a, east on b\n{text}");
    let (west, east) = (pod(&report, "west"), pod(&report, "east"));
    assert!(west.cluster_stats.ops_routed > 0, "{text}");
    assert_eq!(
        east.cluster_stats.ops_applied + west.cluster_stats.ops_forwarded,
        west.cluster_stats.ops_routed,
        "every push west routed reached east through the bridges\n{text}"
    );
    assert!(east.ops.transport.p50_ns > 0, "{text}");
    assert!(
        west.cluster_stats.handoffs_out >= 1 && east.cluster_stats.handoffs_in >= 1,
        "the projectile was handed across hosts\n{text}"
    );
    assert_eq!(
        report.totals.cluster.handoffs_out, report.totals.cluster.handoffs_in,
        "{text}"
    );
    assert!(
        report.totals.cluster.contacts_received > 0,
        "a contact report crossed hosts\n{text}"
    );
}

/// `grid` on two hosts (south-west and south-east on `a`, north-west and north-east on `b`):
/// the pods of each host push and touch the other's balls through the bridges (routed ops from
/// the southern pods applied by the northern ones), and every entity ends owned once. (In one
/// world almost no ball crosses a seam of `grid` within 600 ticks, so hand-offs across hosts
/// are `crossfire`'s test, where its shot is handed over.)
/// At 60 Hz: at 120 Hz four `grid` pods beside this file's other tests overran most ticks on
/// a 2-core machine and lost frames to full buffers, which says the machine is slow, not that
/// the bridges lose anything.
#[test]
fn grid_on_two_hosts_pushes_across_hosts() {
    let Some(mut plan) = plan("grid.toml", 2, 60.0, 600) else {
        return;
    };
    // This one on prefixes alone (`--no-namespaces`), so both ways of simulating hosts run.
    plan.hosts.namespaces = false;
    let (report, nodes) = run::run_pods(&plan, &AtomicBool::new(false), |_| {})
        .unwrap_or_else(|e| panic!("grid on two hosts: {e}"));
    let text = assert_hosts_hold(&report);
    assert_eq!(
        report.hosts.as_ref().expect("hosts").layout,
        ["a", "a", "b", "b"]
    );
    assert_eq!(report.ownership.owned_once, 2500, "{text}");
    let simulated_as = &report.hosts.as_ref().expect("hosts").simulated_as;
    assert!(
        simulated_as.starts_with(run::SIMULATED_AS) && simulated_as.ends_with("turned off"),
        "{simulated_as}"
    );
    // Pushes from host a's pods applied on host b.
    let crossed: u64 = nodes
        .iter()
        .filter(|n| n.cluster.starts_with("north"))
        .flat_map(|n| &n.ops_by_sender)
        .filter(|(sender, _)| sender.starts_with("south"))
        .map(|(_, stages)| stages.ops)
        .sum();
    assert!(
        crossed > 0,
        "no southern push applied by a northern pod\n{text}"
    );
}

/// Starts the bridge of `host` for `crossfire` laid out on two hosts.
fn bridge(scene: &std::path::Path, host: &str, shm: &str, run_id: &str) -> Child {
    let mut child = Command::new(NODE)
        .arg("bridge")
        .arg(scene)
        .args(["--host", host, "--hosts", "2", "--run-id", run_id])
        .args(["--local", &host_url(shm, host).expect("an shm URL")])
        .env("SEAM_REDIS", redis_url())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .spawn()
        .expect("start a bridge");
    let stdout = child.stdout.take().expect("stdout");
    let mut line = String::new();
    std::io::BufRead::read_line(&mut std::io::BufReader::new(stdout), &mut line)
        .expect("the bridge says it is ready");
    assert!(
        matches!(serde_json::from_str(&line), Ok(BridgeLine::Ready { .. })),
        "{line}"
    );
    child
}

/// Host `b` dies (its pod and its bridge killed): west, on host `a`, takes east for dead across
/// the host boundary and adopts what it owned; every entity ends with one owner.
#[test]
fn a_dead_host_is_adopted_across_hosts() {
    let (Some(_redis), Some(shm)) = (
        TestContext::new(Backend::Redis),
        TestContext::new(Backend::Shm),
    ) else {
        return;
    };
    let scene: PathBuf = scene_path("crossfire.toml");
    let run_id = format!("hostdeath{}", std::process::id());
    let url = shm.url();
    let mut bridges = [
        bridge(&scene, "a", &url, &run_id),
        bridge(&scene, "b", &url, &run_id),
    ];
    let start_at = monotonic_ns() + 500_000_000;
    let pod = |cluster: &str, host: &str| {
        let url = host_url(&url, host).expect("an shm URL");
        start_pod(NODE, &scene, cluster, &url, &run_id, start_at, &[])
    };
    let west = pod("west", "a");
    let mut east = pod("east", "b");
    std::thread::sleep(Duration::from_millis(1500));
    east.kill().expect("SIGKILL east");
    bridges[1].kill().expect("SIGKILL b's bridge");
    let _ = east.wait();
    let _ = bridges[1].wait();
    let (proxies_seen, west): (usize, NodeReport) = finish_pod(west);
    bridges[0].kill().expect("stop a's bridge");
    let _ = bridges[0].wait();
    assert!(
        proxies_seen > 0,
        "west modelled east's crates through the bridges"
    );
    assert_eq!(west.ticks, 480, "west kept ticking");
    assert_eq!(west.cluster_stats.neighbours_lost, 1, "east taken for dead");
    assert!(
        west.cluster_stats.entities_adopted > 0,
        "west adopted east's entities"
    );
    assert_eq!(west.proxies, 0, "no proxy of the dead host is left");
    let scene = seam_bench::scene::load(&scene).expect("scene");
    let ownership = seam_bench::run::ownership::check(&scene, &run_id, &[west]);
    assert!(ownership.holds(), "{ownership:?}");
}

/// The Redis server between two hosts dies for a second and a half and comes back: each host
/// takes the other's clusters for dead and adopts what they owned, the bridges reconnect on
/// their own, each side hands back what it adopted when the other is heard again, and every
/// entity ends with one owner.
#[test]
fn a_redis_outage_between_hosts_is_ridden_out() {
    let Some(mut server) = seam_tests::private_redis() else {
        return;
    };
    let Some(mut plan) = plan("crossfire.toml", 2, 120.0, 720) else {
        return;
    };
    plan.hosts.redis = server.url();
    let stop = std::sync::Arc::new(AtomicBool::new(false));
    let running = {
        let stop = std::sync::Arc::clone(&stop);
        std::thread::spawn(move || run::run(&plan, &stop, |_| {}))
    };
    std::thread::sleep(Duration::from_millis(2500));
    server.kill();
    std::thread::sleep(Duration::from_millis(1500));
    server.restart().expect("the server comes back");
    let report = running
        .join()
        .expect("the run thread")
        .unwrap_or_else(|e| panic!("crossfire through an outage: {e}"));
    let text = run::document(&report).text();
    let c = &report.totals.cluster;
    assert!(c.neighbours_lost >= 1, "the outage was felt\n{text}");
    assert_eq!(c.neighbours_rejoined, c.neighbours_lost, "{text}");
    assert!(
        c.entities_adopted > 0 && c.entities_returned == c.entities_adopted + c.handoffs_reclaimed,
        "what was adopted went back\n{text}"
    );
    assert!(report.ownership.holds(), "{:?}\n{text}", report.ownership);
}

/// `seam network` on `crossfire` at one delay: the pods record every authority flip and the
/// hand-offs are judged against the single world (none left untracked), with every hit.
#[test]
fn network_trials_judge_every_hand_off() {
    let (Some(_redis), Some(_shm)) = (
        TestContext::new(Backend::Redis),
        TestContext::new(Backend::Shm),
    ) else {
        return;
    };
    let path = scene_path("crossfire.toml");
    let scene = seam_bench::scene::load(&path).expect("scene");
    let plan = seam_bench::network::NetworkPlan {
        scenes: vec![(path, scene)],
        delays_ms: vec![2.0],
        jitter_ms: 0.0,
        rate: 240.0,
        stagger: false,
        exchange: true,
        redis: redis_url(),
        node_command: vec![NODE.into()],
    };
    let trials = seam_bench::network::run(&plan, |_, _, _| {}).expect("a network trial");
    let text = seam_bench::network::document(&trials).text();
    let a = &trials[0].result.accuracy;
    assert!(a.handoffs >= 1, "{text}");
    assert_eq!(a.handoffs_untracked, 0, "every hand-off judged\n{text}");
    assert_eq!(a.hit_recall, Some(1.0), "{text}");
}
