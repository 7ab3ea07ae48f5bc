//! `seam run`: a scene as co-hosted cluster pods, one process per cluster, with progress, an
//! optional recording and live inspector, and the merged report.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use seam_bench::accuracy::{self, AgainstOneWorld, JudgedRun};
use seam_bench::console::Progress;
use seam_bench::error::{BenchError, BenchResult};
use seam_bench::inspect::{LiveRecording, Served, Server};
use seam_bench::node::{self, ModelArgs, NodeReport};
use seam_bench::record::PartsDir;
use seam_bench::relay::Delay;
use seam_bench::run::{self, HostsPlan, RunPlan, RunReport};

use super::{expand_transport, node_command};
use crate::cli::Output;

/// `seam run`'s flags.
#[derive(clap::Args)]
pub(crate) struct RunArgs {
    /// The scene file (TOML), e.g. bench/scenes/crossfire.toml.
    scene: PathBuf,
    /// Transport URL for every pod: `shm`, `redis://host:port` (`redis` alone means
    /// redis://127.0.0.1:6379), or `redis-cluster://host:port,host:port` (seed nodes of a Redis
    /// Cluster; `tools/redis-cluster up` starts one on loopback and prints its URL).
    #[arg(long, default_value = "shm")]
    transport: String,
    /// Ticks per second; 0 ticks as fast as each pod can.
    #[arg(long, default_value_t = 60.0)]
    rate: f64,
    /// Ticks to run (default: the scene's `ticks`).
    #[arg(long)]
    ticks: Option<u64>,
    #[command(flatten)]
    model: ModelArgs,
    /// Stack this many copies of every grid entity along y, `spacing[1]` apart: the same
    /// traffic with more entities (`grid` holds 2 500 balls per layer).
    #[arg(long, default_value_t = 1)]
    layers: u32,
    /// Run the scene cut into this many clusters, one pod each, as `seam capacity`'s `seam:N`
    /// rows cut it: its own layout when it has N clusters, else the box its regions span cut
    /// into a grid of N cells across x and z (clusters `part-0`, `part-1`, ...), each entity
    /// in the cell its first copy starts in. Refused for a scene with scripted hand-offs.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pods: Option<u32>,
    #[command(flatten)]
    hosts: HostsArgs,
    /// Pod i of n ticks i/n of a period after pod 0, so co-hosted pods do not all want a core
    /// at once (default: every pod ticks at the same moment, which the exchange of routed ops
    /// before the step needs to land them on the tick they were written; staggered, the
    /// exchange waits for each later neighbour up to a quarter of a tick and mostly misses).
    #[arg(long)]
    stagger: bool,
    /// Do not judge the run against one world. By default, once the pods are done, the same
    /// scene runs here for as many ticks as one world and three times again as its noise floor
    /// (bodies inserted in reverse order, each dynamic one moved 1 µm in a direction of its
    /// own; the farthest of the three), and the report says how far the pods' bodies ended
    /// from it, against the floor, with projectile hits and hand-off jumps. Skip it on a
    /// scene so large that four more worlds of it cost too long.
    #[arg(long)]
    no_judge: bool,
    /// Each pod signs what it publishes with its own cluster's ed25519 key and drops any
    /// frame no pod of the run signed, or signed as another cluster (keys made for the run,
    /// removed after; see `seam keys`). Costs about 70 µs a message on this VM (`seam ping`).
    #[arg(long)]
    sign: bool,
    #[command(flatten)]
    record: RecordArgs,
    #[command(flatten)]
    output: Output,
}

/// Where `seam run` puts its pods: one host, or several simulated ones.
#[derive(Debug, clap::Args)]
struct HostsArgs {
    /// Run the pods on this many simulated hosts (for a scene whose clusters name no `host`;
    /// a scene that names them runs on its own hosts without this flag). Pods of one host share
    /// memory (the host's own iceoryx2 prefix); one `seam bridge` per host carries what crosses
    /// hosts over Redis (`--redis`). As root each host is a network namespace made by the run
    /// (and removed after) that reaches Redis only over its veth pair; otherwise the run says
    /// so and uses prefixes alone. Needs `--transport shm`.
    #[arg(long)]
    hosts: Option<u32>,
    /// The Redis server between hosts (on this machine's loopback for simulated hosts), or a
    /// Redis Cluster (`redis-cluster://host:port,...`).
    #[arg(long, default_value = "redis://127.0.0.1:6379")]
    redis: String,
    /// Simulated latency: delay everything between one host's bridge and Redis by this many ms
    /// each way (a relay in front of Redis; this kernel has no netem).
    #[arg(long, default_value_t = 0.0)]
    delay_ms: f64,
    /// Plus up to this many ms more per chunk, uniformly at random (order kept).
    #[arg(long, default_value_t = 0.0)]
    jitter_ms: f64,
    /// The host whose traffic is delayed (default: the last).
    #[arg(long)]
    delayed_host: Option<String>,
    /// Simulate hosts by iceoryx2 prefix alone, even as root (no network namespaces).
    #[arg(long)]
    no_namespaces: bool,
}

/// Recording a run, and looking at it while it runs.
#[derive(clap::Args, Clone)]
struct RecordArgs {
    /// Record the run into FILE: each pod writes its own stream (what it owned and where,
    /// its proxies, the routed ops it applied, contacts reported to it, its tick time), merged
    /// at the end. Look at it with `seam inspect FILE`.
    #[arg(long, value_name = "FILE")]
    record: Option<PathBuf>,
    /// Serve the inspector on loopback while the pods run, updated four times a second from
    /// what they record; it stops with the run (keep the whole run with --record FILE and
    /// `seam inspect FILE --serve`).
    #[arg(long)]
    inspect: bool,
    /// Where --inspect listens (port 0: any free port, printed).
    #[arg(long, default_value = "127.0.0.1:0", value_name = "ADDR")]
    inspect_addr: String,
}

impl RunArgs {
    fn plan(&self) -> RunPlan {
        let (model, hosts) = (&self.model, &self.hosts);
        RunPlan {
            rate: self.rate,
            ticks: self.ticks,
            proxy_mode: model.proxy_mode,
            authority: model.authority,
            replication_interval: model.replication_interval,
            coupling: !model.no_coupling,
            exchange: !model.no_exchange,
            quantize: model.quantize,
            keyframe_ticks: model.keyframe_ticks,
            layers: self.layers,
            stagger: self.stagger,
            // The flips are what its hand-offs are judged by.
            track_flips: !self.no_judge,
            sign: self.sign,
            hosts: HostsPlan {
                count: hosts.hosts,
                redis: expand_transport(&hosts.redis),
                delay: Delay {
                    base: Duration::from_secs_f64(hosts.delay_ms.max(0.0) / 1e3),
                    jitter: Duration::from_secs_f64(hosts.jitter_ms.max(0.0) / 1e3),
                },
                delayed_host: hosts.delayed_host.clone(),
                namespaces: !hosts.no_namespaces,
            },
            ..RunPlan::new(self.scene.clone(), expand_transport(&self.transport))
        }
    }
}

/// Runs the pods, prints the report, and fails if an entity was lost or owned twice.
pub(crate) fn main(args: &RunArgs) -> BenchResult<()> {
    let mut plan = args.plan();
    let split = args
        .pods
        .map(|pods| split_scene(&args.scene, pods))
        .transpose()?;
    if let Some(split) = &split {
        plan.scene.clone_from(split);
    }
    let judged = run_scene(plan, &args.record, !args.no_judge);
    if let Some(split) = &split {
        // Best effort: a temporary file.
        let _ = std::fs::remove_file(split);
    }
    let judged = judged?;
    args.output.report(&judged, accuracy::judged_document);
    let report = &judged.run;
    if report.ownership.holds() {
        Ok(())
    } else {
        Err(BenchError::Failed(format!(
            "seam run: {} entities lost and {} owned twice at the end (see the report)",
            report.ownership.lost.len(),
            report.ownership.duplicated.len()
        )))
    }
}

/// `scene` cut into `pods` clusters (`Scene::split_into`), written where the pods can read it.
fn split_scene(scene: &Path, pods: u32) -> BenchResult<PathBuf> {
    let split = seam_bench::scene::load(scene)?.split_into(pods as usize)?;
    let stem = scene
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy());
    let path = std::env::temp_dir().join(format!(
        "seam-run-{}-{stem}-{pods}-pods.toml",
        std::process::id()
    ));
    seam_bench::scene::save(&split, &path)?;
    eprintln!(
        "seam run: {} cut into {pods} clusters: {}",
        scene.display(),
        split
            .clusters
            .iter()
            .map(|c| c.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(path)
}

/// This executable starts the pods; the recording, if asked for, is kept even when the run
/// fails.
fn run_scene(mut plan: RunPlan, record: &RecordArgs, judge: bool) -> BenchResult<JudgedRun> {
    plan.node_command = node_command()?;
    let stop = node::stop_flag()?;
    eprintln!(
        "seam run: {} on {}, one pod per cluster",
        plan.scene.display(),
        seam_transport::redact_url(&plan.transport)
    );
    let parts = if record.record.is_some() || record.inspect {
        Some(PartsDir::beside(record.record.as_deref())?)
    } else {
        None
    };
    plan.record_dir = parts.as_ref().map(|p| p.dir.clone());
    let live = match (&parts, record.inspect) {
        (Some(parts), true) => {
            let live = LiveRecording::watch(&parts.dir);
            let server = Server::start(&record.inspect_addr, Served::Live(live.clone()))?;
            eprintln!("seam run: inspector at {}", server.url());
            Some((live, server))
        }
        _ => None,
    };
    let ran = run_pods_shown(&plan, &stop);
    if let (Some((live, _server)), Some(parts)) = (&live, &parts) {
        live.finish(&parts.dir);
        if let Some(problem) = live.problem() {
            eprintln!("seam run: inspector: {problem}");
        }
    }
    if let (Some(parts), Some(out)) = (&parts, &record.record) {
        // Even a failed run's recording is worth keeping: it shows what went wrong.
        match parts.merge_into(out, &[], "seam run") {
            Ok(summary) => eprintln!("seam run: {}", summary.line(out)),
            Err(e) => eprintln!("seam run: cannot write {}: {e}", out.display()),
        }
    }
    let (report, nodes) = ran?;
    let stopped = stop.load(std::sync::atomic::Ordering::Relaxed);
    if judge && stopped {
        eprintln!("seam run: stopped early, so not judged against one world");
    }
    let against_one_world = if judge && !stopped {
        eprintln!(
            "seam run: judging against one world (the scene run here four times: one world and \
             the three of its noise floor)"
        );
        Some(AgainstOneWorld::judge(&plan, &nodes)?)
    } else {
        None
    };
    Ok(JudgedRun {
        run: report,
        against_one_world,
    })
}

/// The pods, with progress on the console.
fn run_pods_shown(plan: &RunPlan, stop: &AtomicBool) -> BenchResult<(RunReport, Vec<NodeReport>)> {
    let shown = Progress::new(None);
    run::run_pods(plan, stop, |progress| {
        let pods: Vec<String> = progress
            .pods
            .iter()
            .flatten()
            .map(|p| p.to_string())
            .collect();
        let pods = if pods.is_empty() {
            "starting".to_owned()
        } else {
            pods.join(" · ")
        };
        shown.status(&format!("[{:5.1} s] {pods}", progress.elapsed_s));
    })
}
