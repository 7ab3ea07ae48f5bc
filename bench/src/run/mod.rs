//! `seam run`: the main job — one `seam node` process per cluster of a scene on this host,
//! progress while they run, and one report when they are done.
//!
//! Every pod gets the same run id (so they agree on ids and no other run hears them) and a
//! start time on the host's monotonic clock, a moment after launch, and they tick in phase:
//! with the exchange of routed ops before the step (`ClusterConfig::exchange`), a tick is a
//! barrier between neighbours, and pods in phase see each other's steps as lock-step clusters
//! do. `stagger` starts pod `i` of `n` `i/n` of a period after pod 0 instead, so co-hosted
//! pods do not all want a core at the same moment (what the exchange then waits for is mostly
//! late: see BENCHMARKS.md). Each pod prints JSON lines ([`NodeLine`]); this side reads them, shows
//! progress, and merges the final reports: per pod its ticks, tick-time percentiles and
//! overruns, entities and proxies, ops, contacts, hand-offs and drops; for all pods together the
//! routed-op stages. SIGINT or SIGTERM is passed on to the pods, which stop after their current
//! tick and still report.

mod hosts;
mod netns;
pub mod ownership;
mod phases;
mod report;
mod signing;

use std::ffi::OsString;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStderr, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use seam_proxy::monotonic_ns;

use crate::error::{BenchError, BenchResult};
use crate::node::{AuthorityArgs, NodeLine, NodeProgress, NodeReport, ProxyModeArg};
pub use hosts::{HostsPlan, HostsSummary, SIMULATED_AS};
pub use report::{PodSummary, RunReport, document};

/// What `seam run` runs.
pub struct RunPlan {
    /// The scene file.
    pub scene: PathBuf,
    /// Transport URL for every pod.
    pub transport: String,
    /// Ticks per second (0: as fast as possible).
    pub rate: f64,
    /// Ticks (default: the scene's).
    pub ticks: Option<u64>,
    /// How neighbour entities are modelled.
    pub proxy_mode: ProxyModeArg,
    /// Which hand-offs the pods make.
    pub authority: AuthorityArgs,
    /// A replication frame every this many ticks.
    pub replication_interval: u64,
    /// Whether contacts push across the seam (see `ClusterConfig::coupling`).
    pub coupling: bool,
    /// Routed ops exchanged before the step (see `seam_proxy::ClusterConfig::exchange`).
    pub exchange: bool,
    /// Quantized replication states (see `ModelArgs::quantize`).
    pub quantize: bool,
    /// A keyframe at most every this many ticks (see `ModelArgs::keyframe_ticks`).
    pub keyframe_ticks: u64,
    /// Copies of every grid entity stacked along y.
    pub layers: u32,
    /// Shared by the pods of this run.
    pub run_id: String,
    /// The command that starts a pod, before its flags: `[seam, "node"]`.
    pub node_command: Vec<OsString>,
    /// How long after launch tick 0 is due (time for pods to start and open the transport).
    pub start_delay: Duration,
    /// Stagger the pods over the period instead of ticking them all at the same moment.
    pub stagger: bool,
    /// Hosts the pods run on (one unless the scene or `--hosts` says more).
    pub hosts: HostsPlan,
    /// Pods record every authority flip (`seam node --track-flips`).
    pub track_flips: bool,
    /// Each pod records its stream into a part file in this folder (`seam node --record`);
    /// see [`crate::record`].
    pub record_dir: Option<PathBuf>,
    /// Each pod signs with its own cluster's key and checks every frame against the run's
    /// keyring (`seam run --sign`; see `seam_transport::signing`).
    pub sign: bool,
}

impl RunPlan {
    /// A plan to run `scene` on `transport` with the defaults `seam run` has: 60 Hz, the
    /// scene's ticks, Fixed proxies, the spatial policy, a frame every tick, coupling, exact
    /// states, one layer, one host, pods staggered and started by this executable's `node`
    /// command, a fresh run id.
    pub fn new(scene: impl Into<PathBuf>, transport: impl Into<String>) -> Self {
        Self {
            scene: scene.into(),
            transport: transport.into(),
            rate: 60.0,
            ticks: None,
            proxy_mode: ProxyModeArg::Fixed,
            authority: AuthorityArgs::default(),
            replication_interval: 1,
            coupling: true,
            exchange: true,
            quantize: false,
            keyframe_ticks: seam_proxy::DEFAULT_KEYFRAME_TICKS,
            layers: 1,
            run_id: fresh_run_id(),
            node_command: Vec::new(),
            start_delay: Duration::from_millis(750),
            stagger: false,
            hosts: HostsPlan::default(),
            track_flips: false,
            record_dir: None,
            sign: false,
        }
    }

    /// How much later than pod 0 pod `index` of `pods` ticks, ns (see the module docs).
    pub fn pod_offset_ns(&self, index: usize, pods: u64) -> u64 {
        if !self.stagger || self.rate <= 0.0 {
            0
        } else {
            (1e9 / self.rate) as u64 * index as u64 / pods
        }
    }
}

/// One pod to start.
pub struct PodLaunch<'a> {
    /// Its place in the scene's clusters (tags its lines).
    pub index: usize,
    /// Scene cluster.
    pub cluster: &'a str,
    /// Its tick 0, CLOCK_MONOTONIC ns.
    pub start_at: u64,
    /// Ticks of the run.
    pub ticks: u64,
    /// Restarted into a running world (`seam node --rejoin`).
    pub rejoin: bool,
    /// Counts the panic messages on its stderr.
    pub panics: &'a Arc<AtomicU64>,
    /// Its transport URL when not the plan's (a pod on one of several hosts).
    pub transport: Option<&'a str>,
    /// The network namespace it runs in (a pod on a simulated host), if any.
    pub namespace: Option<&'a str>,
    /// Where it writes its ledger (`seam node --ledger`), if anywhere.
    pub ledger: Option<&'a Path>,
}

/// Numbers pods' part files apart (see [`RunPlan::record_dir`]).
static PART_FILES: AtomicU64 = AtomicU64::new(0);

/// A line a pod wrote, tagged with its index, or why it could not be read.
pub type PodLine = (usize, BenchResult<NodeLine>);

/// Starts one `seam node` of `plan`, a thread that sends its JSON lines to `lines`, and one
/// that forwards its stderr to this one's, each line tagged `[cluster]` and printed above any
/// progress bar (see [`crate::console`]), counting panic messages in `launch.panics`. The
/// forwarder ends when the pod's stderr closes: join it before reading the count.
pub fn spawn_pod(
    plan: &RunPlan,
    launch: &PodLaunch<'_>,
    lines: &mpsc::Sender<PodLine>,
) -> BenchResult<(Child, JoinHandle<()>)> {
    let (program, leading) = plan
        .node_command
        .split_first()
        .ok_or_else(|| BenchError::process("seam", "no command to start a pod"))?;
    let mut command = hosts::in_namespace(launch.namespace, program);
    command
        .args(leading)
        .arg(&plan.scene)
        .args(["--cluster", launch.cluster])
        // Through the environment, not the command line, which every user of the host can
        // read: the URL may hold a password.
        .env(
            "SEAM_TRANSPORT",
            launch.transport.unwrap_or(&plan.transport),
        )
        .args(["--rate", &plan.rate.to_string()])
        .args(["--ticks", &launch.ticks.to_string()])
        .args(["--run-id", &plan.run_id])
        .args(["--proxy-mode", proxy_mode_name(plan.proxy_mode)])
        .args(plan.authority.to_args())
        .args([
            "--replication-interval",
            &plan.replication_interval.to_string(),
        ])
        .args(["--layers", &plan.layers.to_string()])
        .args(["--start-at", &launch.start_at.to_string(), "--quiet"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if launch.rejoin {
        command.arg("--rejoin");
    }
    if !plan.exchange {
        command.arg("--no-exchange");
    }
    if !plan.coupling {
        command.arg("--no-coupling");
    }
    if plan.quantize {
        command.arg("--quantize");
    }
    if plan.track_flips {
        command.arg("--track-flips");
    }
    command.args(["--keyframe-ticks", &plan.keyframe_ticks.to_string()]);
    if let Some(path) = launch.ledger {
        command.arg("--ledger").arg(path);
    }
    if let Some(dir) = &plan.record_dir {
        // One part file per incarnation of a pod (a restarted pod writes a new one).
        let n = PART_FILES.fetch_add(1, Ordering::Relaxed);
        command
            .arg("--record")
            .arg(dir.join(format!("{}-{n}.part", launch.cluster)));
    }
    let mut child = command
        .spawn()
        .map_err(|e| BenchError::io("start", format!("the pod of {:?}", launch.cluster), e))?;
    let stdout = child
        .stdout
        .take()
        .ok_or_else(|| BenchError::process(format!("pod {:?}", launch.cluster), "no stdout"))?;
    let stderr = child
        .stderr
        .take()
        .ok_or_else(|| BenchError::process(format!("pod {:?}", launch.cluster), "no stderr"))?;
    let forwarder = forward_stderr(stderr, launch.cluster, Arc::clone(launch.panics));
    let (lines, index) = (lines.clone(), launch.index);
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let parsed = line
                .map_err(|e| BenchError::io("read", "a pod's output", e))
                .and_then(|text| {
                    serde_json::from_str::<NodeLine>(&text).map_err(|e| {
                        BenchError::process("a pod", format!("unreadable line {text:?}: {e}"))
                    })
                });
            if lines.send((index, parsed)).is_err() {
                break;
            }
        }
    });
    Ok((child, forwarder))
}

/// Forwards a pod's stderr (see [`spawn_pod`]).
fn forward_stderr(stderr: ChildStderr, name: &str, panics: Arc<AtomicU64>) -> JoinHandle<()> {
    let name = name.to_owned();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if line.contains("panicked at") {
                panics.fetch_add(1, Ordering::Relaxed);
            }
            crate::console::line(&format!("[{name}] {line}"));
        }
    })
}

/// Where the run is, for progress output.
pub struct RunProgress<'a> {
    /// Seconds since launch.
    pub elapsed_s: f64,
    /// The latest progress of each pod that has sent one.
    pub pods: &'a [Option<NodeProgress>],
}

/// A run id no other run on this host has now.
pub fn fresh_run_id() -> String {
    format!("{}-{}", std::process::id(), monotonic_ns())
}

/// Kills the pods still running when dropped (an error path must not leave them behind).
struct Pods(Vec<(String, Child)>);

impl Drop for Pods {
    fn drop(&mut self) {
        for (_, child) in &mut self.0 {
            if let Ok(None) = child.try_wait() {
                let _ = child.kill();
                let _ = child.wait();
            }
        }
    }
}

impl Pods {
    fn signal_all(&mut self, signal: rustix::process::Signal) {
        for (_, child) in &mut self.0 {
            if let Ok(None) = child.try_wait()
                && let Some(pid) = rustix::process::Pid::from_raw(child.id() as i32)
            {
                let _ = rustix::process::kill_process(pid, signal);
            }
        }
    }
}

/// Starts the pods, waits for them while calling `progress` about once a second, and merges
/// their reports. `stop` (set by a signal) ends the run early.
pub fn run(
    plan: &RunPlan,
    stop: &AtomicBool,
    progress: impl FnMut(&RunProgress<'_>),
) -> BenchResult<RunReport> {
    run_pods(plan, stop, progress).map(|(report, _)| report)
}

/// The Redis server a run's ops go through, if any: its transport's, or the hosts' server
/// when the scene's clusters sit on more than one simulated host.
fn redis_of<'a>(plan: &'a RunPlan, scene: &crate::scene::Scene) -> BenchResult<Option<&'a str>> {
    Ok(if plan.transport.starts_with("redis://") {
        Some(plan.transport.as_str())
    } else if scene
        .host_layout(plan.hosts.count)?
        .iter()
        .any(|h| h != "a")
    {
        Some(plan.hosts.redis.as_str())
    } else {
        None
    })
}

/// When a run launched at `launched` is stopped, its pods still running. Generous: the
/// planned run, plus start-up, plus ticks that may run slower than planned.
fn run_deadline(plan: &RunPlan, ticks: u64, launched: Instant) -> Instant {
    let planned = if plan.rate > 0.0 {
        ticks as f64 / plan.rate
    } else {
        0.0
    };
    launched + plan.start_delay + Duration::from_secs_f64(planned * 3.0) + Duration::from_secs(60)
}

/// Waits for every pod and its stderr forwarder; notes what ended badly. Whether each pod
/// failed, in order.
fn wait_for_pods(
    pods: &mut Pods,
    forwarders: Vec<std::thread::JoinHandle<()>>,
    panics: &AtomicU64,
    problems: &mut Vec<String>,
) -> BenchResult<Vec<bool>> {
    let mut failed = Vec::new();
    for (name, child) in &mut pods.0 {
        let status = child
            .wait()
            .map_err(|e| BenchError::io("wait for", format!("pod {name:?}"), e))?;
        failed.push(!status.success());
        if !status.success() {
            problems.push(format!(
                "pod {name:?} exited with {status} (its error is above)"
            ));
        }
    }
    // Every pod has exited: the forwarders end once they have passed on the last lines.
    for forwarder in forwarders {
        if forwarder.join().is_err() {
            problems.push("a stderr forwarder panicked".into());
        }
    }
    let panicked = panics.load(Ordering::Relaxed);
    if panicked > 0 {
        problems.push(format!(
            "{panicked} panic messages on the pods' stderr (above)"
        ));
    }
    Ok(failed)
}

/// The reports the pods sent, in order; a pod that ended well without one is a problem.
fn complete_reports(
    pods: &Pods,
    reports: Vec<Option<NodeReport>>,
    failed: &[bool],
    problems: &mut Vec<String>,
) -> Vec<NodeReport> {
    let mut complete = Vec::new();
    for (((name, _), report), &failed) in pods.0.iter().zip(reports).zip(failed) {
        match report {
            Some(report) => complete.push(report),
            None if !failed => problems.push(format!("pod {name:?} sent no report")),
            None => {}
        }
    }
    complete
}

/// Pod `index`'s transport URL when not the plan's: its host's (through a bridge), with its
/// signing settings.
fn pod_url(
    plan: &RunPlan,
    bridges: Option<&hosts::Bridges>,
    keys: Option<&signing::RunKeys>,
    index: usize,
) -> BenchResult<Option<String>> {
    let url = match bridges {
        Some(bridges) => Some(bridges.pod_url(plan, index)?),
        None => None,
    };
    Ok(match keys {
        Some(keys) => Some(keys.url(index, url.as_deref().unwrap_or(&plan.transport))),
        None => url,
    })
}

/// As [`run`], also returning each pod's own report (hits, final positions, histograms).
pub fn run_pods(
    plan: &RunPlan,
    stop: &AtomicBool,
    mut progress: impl FnMut(&RunProgress<'_>),
) -> BenchResult<(RunReport, Vec<NodeReport>)> {
    let scene = crate::scene::load(&plan.scene)?.stacked(plan.layers)?;
    let ticks = plan.ticks.unwrap_or(scene.ticks);
    let start_at = monotonic_ns() + plan.start_delay.as_nanos() as u64;
    let launched = Instant::now();
    let (lines, incoming) = mpsc::channel::<PodLine>();
    let mut pods = Pods(Vec::new());
    let panics = Arc::new(AtomicU64::new(0));
    let mut forwarders = Vec::new();
    let pods_n = scene.clusters.len() as u64;
    let redis_url = redis_of(plan, &scene)?;
    let redis_cpu_start = redis_url.and_then(crate::redis_server::server_cpu_s);
    let bridges = hosts::Bridges::start(plan, &scene)?;
    let keys = signing::RunKeys::for_plan(plan, &scene)?;
    let start_at = start_at.max(monotonic_ns() + plan.start_delay.as_nanos() as u64);
    for (index, cluster) in scene.clusters.iter().enumerate() {
        let url = pod_url(plan, bridges.as_ref(), keys.as_ref(), index)?;
        let (child, forwarder) = spawn_pod(
            plan,
            &PodLaunch {
                index,
                cluster: &cluster.name,
                start_at: start_at + plan.pod_offset_ns(index, pods_n),
                ticks,
                rejoin: false,
                panics: &panics,
                transport: url.as_deref(),
                namespace: bridges.as_ref().and_then(|b| b.pod_namespace(index)),
                ledger: None,
            },
            &lines,
        )?;
        pods.0.push((cluster.name.clone(), child));
        forwarders.push(forwarder);
    }
    drop(lines);

    let deadline = run_deadline(plan, ticks, launched);
    let mut latest: Vec<Option<NodeProgress>> = vec![None; pods.0.len()];
    let mut reports: Vec<Option<NodeReport>> = vec![None; pods.0.len()];
    let mut problems: Vec<String> = Vec::new();
    let mut last_shown = Instant::now();
    let mut signalled = false;
    loop {
        match incoming.recv_timeout(Duration::from_millis(100)) {
            Ok((index, Ok(NodeLine::Progress(p)))) => latest[index] = Some(*p),
            Ok((index, Ok(NodeLine::Report(r)))) => reports[index] = Some(*r),
            Ok((index, Err(e))) => problems.push(format!("pod {:?}: {e}", pods.0[index].0)),
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
            Err(mpsc::RecvTimeoutError::Timeout) => {}
        }
        if last_shown.elapsed() >= Duration::from_secs(1) {
            last_shown = Instant::now();
            progress(&RunProgress {
                elapsed_s: launched.elapsed().as_secs_f64(),
                pods: &latest,
            });
        }
        if !signalled && (stop.load(Ordering::Relaxed) || Instant::now() > deadline) {
            if !stop.load(Ordering::Relaxed) {
                problems.push(format!(
                    "the pods were still running after {:.0} s: stopped",
                    launched.elapsed().as_secs_f64()
                ));
            }
            pods.signal_all(rustix::process::Signal::TERM);
            signalled = true;
        }
    }
    let failed = wait_for_pods(&mut pods, forwarders, &panics, &mut problems)?;
    let wall_s = launched.elapsed().as_secs_f64();
    let complete = complete_reports(&pods, reports, &failed, &mut problems);
    let hosts = match bridges.map(hosts::Bridges::finish).transpose() {
        Ok(hosts) => hosts,
        Err(e) => {
            problems.push(e.to_string());
            None
        }
    };
    if !problems.is_empty() {
        return Err(BenchError::Failed(problems.join("\n")));
    }
    let mut report = RunReport::new(
        &scene,
        seam_transport::redact_url(&plan.transport),
        plan,
        wall_s,
        &complete,
    );
    report.redis_cpu_s = redis_url
        .and_then(crate::redis_server::server_cpu_s)
        .zip(redis_cpu_start)
        .map(|(end, start)| end - start);
    report.hosts = hosts.map(|mut hosts| {
        hosts.split_ops(&scene, &complete);
        hosts
    });
    Ok((report, complete))
}

fn proxy_mode_name(mode: ProxyModeArg) -> &'static str {
    match mode {
        ProxyModeArg::Fixed => "fixed",
        ProxyModeArg::Kinematic => "kinematic",
    }
}
