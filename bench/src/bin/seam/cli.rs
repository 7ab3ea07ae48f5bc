//! `seam`'s command line: the commands and their flags, as clap reads them.

use clap::{Parser, Subcommand};
use seam_bench::accuracy::TrialSettings;
use seam_bench::document::Document;
use seam_bench::node::{ModelArgs, NodeArgs};
use seam_bench::ping::WaitMode;

#[derive(Parser)]
#[command(
    name = "seam",
    version,
    about = "Cross-cluster physics for multiplayer game backends: run and measure seam",
    long_about = "Cross-cluster physics for multiplayer game backends: run and measure seam.\n\n\
        Transports are named by URL: `shm` (iceoryx2 shared memory between processes of this \
        host, no server needed; settings as `shm?prefix=NAME&buffer=N&max_payload=BYTES`), \
        `local` (iceoryx2 inside one process) or `redis://[user:password@]host:port`."
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Subcommand)]
pub(crate) enum Command {
    /// Run a scene as co-hosted cluster pods, one process per cluster, and report (the main job).
    ///
    /// Starts one `seam node` per cluster of the scene on this host, over shared memory unless
    /// told otherwise (no server needed), shows progress, and prints per pod: ticks, tick-time
    /// percentiles and overruns, entities and proxies, ops routed and applied, contacts sent
    /// and received, hand-offs and drops; and for all pods the routed-op stages (queue,
    /// transport, apply, whole) in µs and ticks. Ctrl-C stops the pods, which still report.
    Run {
        /// The scene file (TOML), e.g. bench/scenes/crossfire.toml.
        scene: std::path::PathBuf,
        /// Transport URL for every pod: `shm`, or `redis://host:port` (`redis` alone means
        /// redis://127.0.0.1:6379).
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
        #[command(flatten)]
        hosts: HostsArgs,
        /// Tick every pod at the same moment (default: pod i of n ticks i/n of a period later,
        /// so co-hosted pods do not all want a core at once).
        #[arg(long)]
        in_phase: bool,
        #[command(flatten)]
        record: RecordArgs,
        #[command(flatten)]
        output: Output,
    },
    /// Compare one setting against the single-world reference: accuracy and cost.
    ///
    /// Runs each scene split over its clusters in lock-step (in this process, on iceoryx2's
    /// in-process transport) and as one world owning everything, tick for tick, and prints
    /// position and orientation error (and the body furthest off), projectile hit recall and
    /// precision, momentum error, hand-offs and their jumps, bodies with two owners or none,
    /// bodies that escaped (fell through or flew off where the single world's did not), and the
    /// split run's tick time (per cluster and summed, against the single world's), bytes per
    /// tick, proxies and op delay. `--markdown` prints one table row per scene.
    Compare {
        /// The scene files (TOML), each compared in turn.
        #[arg(required = true)]
        scenes: Vec<std::path::PathBuf>,
        #[command(flatten)]
        knobs: Knobs,
        /// Print, on stderr after every tick, where this entity (its scene name; `name#i` for
        /// a grid copy, as the "largest" line names it) is in the split run and in the single
        /// world, which cluster simulates it, and how far apart the two are.
        #[arg(long, value_name = "NAME")]
        trace: Option<String>,
        /// Record the split run and the single world, tick by tick, into FILE (one scene
        /// only): `seam inspect FILE` then shows each body's distance from its single-world
        /// copy.
        #[arg(long, value_name = "FILE")]
        record: Option<std::path::PathBuf>,
        #[command(flatten)]
        output: Output,
    },
    /// Sweep settings against the single-world reference: `sweep.csv` and charts.
    ///
    /// For each scene, runs one trial (as `seam compare`) per combination of proxy mode (fixed,
    /// kinematic), replication interval (1, 2, 4, 8), observation spread (1, 3, 10 m,
    /// everything) and, for scenes that fire projectiles, projectile speed (10–2 000 m/s) and
    /// CCD (off, on), in lock-step; per proxy mode and interval, exact and quantized states at
    /// the scene's own settings (the quantization axis); then the transport axis: the scene as free-running pods
    /// (`seam run`) on shm and Redis, per proxy mode at the shortest and longest interval,
    /// compared by hits and final positions, with routed-op latency. Writes OUT/sweep.csv (one
    /// row per trial, every metric) and, as SVG and PNG, OUT/accuracy_vs_cost_SCENE (position or
    /// hit error against CPU per tick summed over clusters and against bytes per tick, Pareto
    /// front marked) and, for scenes with hits, OUT/hit_recall_vs_speed_SCENE_{fixed,kinematic}.
    Sweep {
        /// Scene files (default: gallery, corridor, stacks, light-on-heavy, equal-masses,
        /// seam-stack, grid and crossfire of bench/scenes/).
        #[arg(long = "scene")]
        scenes: Vec<std::path::PathBuf>,
        /// A reduced grid: fixed/kinematic × interval 1, 4 × 50, 500, 2 000 m/s × CCD off/on ×
        /// spread 3 m / everything, and exact/quantized.
        #[arg(long)]
        quick: bool,
        /// Ticks per trial (default: each scene's).
        #[arg(long)]
        ticks: Option<u64>,
        /// Transports for the free-running pods of the transport axis, comma separated
        /// (`redis` alone means redis://127.0.0.1:6379; one that cannot be opened is left out
        /// with a notice; `none` skips the axis).
        #[arg(long, default_value = "shm,redis", value_delimiter = ',')]
        transport: Vec<String>,
        /// Ticks per second of the free-running pods.
        #[arg(long, default_value_t = 240.0)]
        rate: f64,
        /// Where to write the CSV and the charts.
        #[arg(long, default_value = "sweep")]
        out: std::path::PathBuf,
    },
    /// Accuracy against the network between hosts: each scene on two simulated hosts, the second
    /// host's traffic to Redis delayed by each delay in turn.
    ///
    /// Pods run free-running at `--rate` as in `seam run --hosts 2` (network namespaces as root,
    /// else separate shm prefixes; a relay in front of Redis adds the delay, since this kernel
    /// has no netem: the delay is simulated). Each run is compared with a single-world run of
    /// the same ticks: projectile hit recall, final position error, routed-op delay in ticks.
    /// Writes `network.csv` and `accuracy_vs_delay_SCENE.svg`/`.png` into `--out`.
    Network {
        /// Scene files (default: crossfire and gallery of bench/scenes/).
        #[arg(long = "scene")]
        scenes: Vec<std::path::PathBuf>,
        /// One-way delays between host b and Redis, ms, comma separated.
        #[arg(long, default_value = "0,1,5,20", value_delimiter = ',')]
        delays_ms: Vec<f64>,
        /// Up to this much more per chunk, ms, uniformly at random (order kept).
        #[arg(long, default_value_t = 0.0)]
        jitter_ms: f64,
        /// Ticks per second of the pods.
        #[arg(long, default_value_t = 60.0)]
        rate: f64,
        /// Tick both pods at the same moment (default: staggered by half a period, as `seam
        /// run`), which makes every routed op wait a tick whatever the delay.
        #[arg(long)]
        in_phase: bool,
        /// The Redis server between hosts (on this machine's loopback).
        #[arg(long, default_value = "redis://127.0.0.1:6379")]
        redis: String,
        /// Where to write the CSV and the charts.
        #[arg(long, default_value = "network")]
        out: std::path::PathBuf,
    },
    /// Run a scene's pods under faults on a schedule and report what survived.
    ///
    /// The pods run as in `seam run`, on shared memory under a private prefix or, with
    /// `--transport redis`, on a private redis-server this command starts and restarts. Every
    /// `--fault-every-s` one fault in turn: a pod killed with SIGKILL and restarted 2 s later
    /// with `--rejoin` (in the first half of the run only, so every pod's last incarnation
    /// lives long enough to judge its memory); the Redis server killed for 1 s and restarted
    /// (Redis only); a pod stopped with SIGSTOP for 1 s. Between faults, garbage and forged frames go into every
    /// channel four times a second. Prints faults injected and survived, injected frames
    /// against the pods' refusal counters, entities lost or owned twice, routed ops applied,
    /// resent, dropped by reason and lost, frames dropped by reason, adoptions, outages,
    /// panics, and each pod's memory after warm-up. Exits with 1 if a target does not hold
    /// (RELIABILITY.md lists them; a routed op lost is one).
    Chaos {
        /// The scene file (TOML), e.g. bench/scenes/crossfire.toml.
        scene: std::path::PathBuf,
        /// `shm`, or `redis` for a private redis-server (needs `redis-server` on the PATH).
        #[arg(long, default_value = "shm", value_parser = ["shm", "redis"])]
        transport: String,
        /// How long the pods run, seconds.
        #[arg(long, default_value_t = 60.0)]
        duration_s: f64,
        /// Seconds from the end of one fault to the start of the next.
        #[arg(long, default_value_t = 5.0)]
        fault_every_s: f64,
        /// Ticks per second.
        #[arg(long, default_value_t = 60.0)]
        rate: f64,
        /// Stack this many copies of every grid entity along y.
        #[arg(long, default_value_t = 1)]
        layers: u32,
        /// Seeds which pod each fault hits and the garbage.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Give the pods this frame key (`key=` in their URL): the injector, a process without
        /// it, must then see every garbage and forged frame dropped as untagged before any
        /// decoder reads it.
        #[arg(long)]
        key: Option<String>,
        /// Record every pod incarnation's ticks and the faults into FILE (see `seam inspect`).
        #[arg(long, value_name = "FILE")]
        record: Option<std::path::PathBuf>,
        #[command(flatten)]
        output: Output,
    },
    /// Look at a recording: a page to scrub through, a still, or the page's own timings.
    ///
    /// Writes one self-contained HTML page (FILE.html unless --out says where; nothing in it
    /// is fetched from elsewhere): cluster regions and spread seen from above, bodies filled in
    /// their owner's colour, the proxies of the world chosen outlined in their owners' colours,
    /// hand-offs as rings, routed ops as arrows from the issuer's region to the target,
    /// contacts sent back as crosses, a per-cluster tick-time strip, a timeline to play, pause,
    /// step (arrow keys) and scrub. Click a body for its owners over the run and, in a `seam
    /// compare` recording, its distance from its single-world copy. Recordings come from `seam
    /// run`, `seam compare` and `seam chaos` with `--record FILE`; the format is documented in
    /// bench/src/record/mod.rs.
    Inspect(InspectArgs),
    /// One cluster pod: runs its part of a scene over a transport (started by `seam run`, or by
    /// hand on each host).
    ///
    /// Ticks on a schedule (60 Hz unless told otherwise), sleeping on the transport's wake-up
    /// between ticks; stops cleanly on SIGINT or SIGTERM. Writes JSON lines on stdout: progress
    /// about once a second and a final report. Pods of one run must share `--run-id`.
    Node(NodeArgs),
    /// One host's bridge: passes the channels that cross the host boundary between the host's
    /// shared memory and a Redis server (started by `seam run --hosts N`, or by hand, one per
    /// host).
    ///
    /// Pods on one host speak shared memory to each other; the bridge forwards exactly the
    /// replication and physics-events channels that pods on other hosts publish or read, each
    /// once per host, keeping every message's envelope (publisher and number) so receivers
    /// count losses end to end. Writes a JSON line when ready and its report (messages, bytes,
    /// CPU) when SIGINT or SIGTERM stops it.
    Bridge(seam_bench::bridge::BridgeArgs),
    /// Measure one-way latency between two processes (round trip / 2) over each transport.
    ///
    /// Spawns a peer process that echoes every message back, times the round trips and prints
    /// p50 / p99 / p99.9 / max one-way latency and messages per second per transport and size.
    /// Beside each `shm` row it measures plain iceoryx2 (no seam layer, busy-polling) as the
    /// floor, and prints the shm / iceoryx2 and redis / shm ratios of one run.
    Ping {
        /// Transports to compare, comma separated, e.g. `shm,redis://127.0.0.1:6379`.
        /// `redis` alone means redis://127.0.0.1:6379.
        #[arg(long, default_value = "shm", value_delimiter = ',')]
        transport: Vec<String>,
        /// Payload sizes in bytes, comma separated.
        #[arg(long, default_value = "64", value_delimiter = ',')]
        size: Vec<usize>,
        /// Timed round trips per row.
        #[arg(long, default_value_t = 20_000)]
        iterations: u64,
        /// Untimed round trips before them.
        #[arg(long, default_value_t = 2_000)]
        warmup: u64,
        /// How both sides wait for a message: auto spins on shared memory and sleeps on Redis.
        #[arg(long, value_enum, default_value_t = WaitMode::Auto)]
        wait: WaitMode,
        #[command(flatten)]
        output: Output,
        /// Skip the plain-iceoryx2 floor rows.
        #[arg(long)]
        no_floor: bool,
    },
    /// Measure routed-op latency between two processes, stage by stage, per transport.
    ///
    /// This process issues batches of impulses on an entity a child process owns, as real
    /// physics-events frames; the owner applies each frame as soon as it arrives (no tick wait)
    /// and acknowledges it. Stamps on the host monotonic clock give each op's stages: queue
    /// (issued → published), transport (published → received), apply (received → applied) and
    /// the whole. Prints p50 / p99 / p99.9 per stage and ops per second, and the redis / shm
    /// ratio of the transport stage.
    Ops {
        /// Transports to compare, comma separated (`redis` alone means redis://127.0.0.1:6379).
        #[arg(long, default_value = "shm", value_delimiter = ',')]
        transport: Vec<String>,
        /// Ops per frame, comma separated.
        #[arg(long, default_value = "1,16,256", value_delimiter = ',')]
        batch: Vec<usize>,
        /// Answers carried in each frame, comma separated: `off` (none) and `on` (one per op of
        /// the batch, as a pod's frame carries its answers to the ops the other side sent it).
        /// Both, measured in turn, give the cost of acknowledgements as a ratio in one run;
        /// repeat them (`off,on,off,on,off,on`) and the ratio is of the medians.
        #[arg(long, default_value = "off,on", value_delimiter = ',')]
        acks: Vec<AckMode>,
        /// Timed frames per row.
        #[arg(long, default_value_t = 10_000)]
        rounds: u64,
        /// Untimed frames before them.
        #[arg(long, default_value_t = 1_000)]
        warmup: u64,
        /// How both sides wait: auto spins on shared memory and sleeps on Redis.
        #[arg(long, value_enum, default_value_t = WaitMode::Auto)]
        wait: WaitMode,
        #[command(flatten)]
        output: Output,
    },
    /// Check scene files and summarise them (clusters, entities, events, ticks).
    ///
    /// A bad file is reported as FILE:LINE:COLUMN with the field and what is wrong. The format
    /// is described in `bench/src/scene/mod.rs`; `bench/scenes/` has one scene per class of
    /// problem (the scene table of docs/accuracy.md).
    Scene {
        /// Scene files (TOML).
        #[arg(required = true)]
        files: Vec<std::path::PathBuf>,
    },
    /// The owning side of `seam ops` (started by it).
    #[command(hide = true)]
    OpsOwner {
        #[arg(long)]
        transport: String,
        #[arg(long)]
        events: String,
        #[arg(long)]
        ack: String,
        #[arg(long, value_enum)]
        wait: WaitMode,
    },
    /// The peer side of `seam ping` (started by it).
    #[command(hide = true)]
    PingPeer {
        #[arg(long)]
        transport: String,
        #[arg(long)]
        ping: String,
        #[arg(long)]
        pong: String,
        #[arg(long)]
        count: u64,
        #[arg(long, value_enum)]
        wait: WaitMode,
    },
    /// The peer side of the plain-iceoryx2 floor (started by `seam ping`).
    #[command(hide = true)]
    PingFloorPeer {
        #[arg(long)]
        ping: String,
        #[arg(long)]
        pong: String,
        #[arg(long)]
        size: usize,
        #[arg(long)]
        count: u64,
    },
}

/// The settings `seam compare` tries.
#[derive(clap::Args)]
pub(crate) struct Knobs {
    #[command(flatten)]
    model: ModelArgs,
    /// Observation spread of every cluster, m (default: the scene's).
    #[arg(long)]
    spread: Option<f32>,
    /// Proxy every neighbour entity wherever it is (no interest management).
    #[arg(long)]
    everything: bool,
    /// Speed of the scene's projectiles, m/s (default: the scene's).
    #[arg(long)]
    speed: Option<f32>,
    /// CCD on the scene's projectiles: `on` or `off` (default: the scene's).
    #[arg(long, value_parser = ["on", "off"])]
    ccd: Option<String>,
    /// Ticks (default: the scene's).
    #[arg(long)]
    ticks: Option<u64>,
}

impl Knobs {
    pub(crate) fn settings(&self) -> TrialSettings {
        TrialSettings {
            proxy_mode: self.model.proxy_mode.into(),
            authority: self.model.authority,
            replication_interval: self.model.replication_interval.max(1),
            coupling: !self.model.no_coupling,
            quantize: self.model.quantize,
            keyframe_ticks: self.model.keyframe_ticks,
            spread: self.spread,
            interest: !self.everything,
            projectile_speed: self.speed,
            projectile_ccd: self.ccd.as_deref().map(|c| c == "on"),
            ticks: self.ticks,
        }
    }
}

/// `seam inspect`'s flags.
#[derive(clap::Args)]
pub(crate) struct InspectArgs {
    /// The recording.
    pub(crate) file: std::path::PathBuf,
    /// Where to write the page (default: FILE.html).
    #[arg(long, value_name = "PAGE")]
    pub(crate) out: Option<std::path::PathBuf>,
    /// Serve the page on loopback (see --addr) until Ctrl-C instead of writing it.
    #[arg(long)]
    pub(crate) serve: bool,
    /// Where --serve and --measure listen (port 0: any free port).
    #[arg(long, default_value = "127.0.0.1:0", value_name = "ADDR")]
    pub(crate) addr: String,
    /// Draw the view at --tick into this PNG instead.
    #[arg(long, value_name = "PNG")]
    pub(crate) png: Option<std::path::PathBuf>,
    /// The tick a still shows (the first recorded at or after it).
    #[arg(long, default_value_t = 0)]
    pub(crate) tick: u64,
    /// In a still, outline this cluster's proxies in their owners' colours.
    #[arg(long, value_name = "CLUSTER")]
    pub(crate) world: Option<String>,
    /// A still's size, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "1200x800")]
    pub(crate) size: String,
    /// Load the page in headless Chromium (Debian's chromium and chromium-driver) and
    /// print what it measured of itself: load time and random-tick scrub rate.
    #[arg(long)]
    pub(crate) measure: bool,
    /// Ticks --measure draws back to back.
    #[arg(long, default_value_t = 300)]
    pub(crate) frames: u32,
}

/// Recording a run, and looking at it while it runs.
#[derive(clap::Args, Clone)]
pub(crate) struct RecordArgs {
    /// Record the run into FILE: each pod writes its own stream (what it owned and where,
    /// its proxies, the routed ops it applied, contacts reported to it, its tick time), merged
    /// at the end. Look at it with `seam inspect FILE`.
    #[arg(long, value_name = "FILE")]
    pub(crate) record: Option<std::path::PathBuf>,
    /// Serve the inspector on loopback while the pods run, updated four times a second from
    /// what they record; it stops with the run (keep the whole run with --record FILE and
    /// `seam inspect FILE --serve`).
    #[arg(long)]
    pub(crate) inspect: bool,
    /// Where --inspect listens (port 0: any free port, printed).
    #[arg(long, default_value = "127.0.0.1:0", value_name = "ADDR")]
    pub(crate) inspect_addr: String,
}

/// How a command prints what it measured.
#[derive(clap::Args, Clone, Copy)]
pub(crate) struct Output {
    /// Print JSON instead of the table (one object per row for `ping` and `ops`).
    #[arg(long, conflicts_with = "markdown")]
    pub(crate) json: bool,
    /// Print the measured rows as Markdown tables, as BENCHMARKS.md and RELIABILITY.md quote
    /// them.
    #[arg(long)]
    pub(crate) markdown: bool,
}

impl Output {
    /// Prints measured rows as a table, as Markdown, or as one JSON object per line.
    pub(crate) fn rows<R: serde::Serialize>(self, rows: &[R], document: fn(&[R]) -> Document) {
        if self.json {
            for row in rows {
                println!("{}", serde_json::to_string(row).expect("rows serialise"));
            }
        } else {
            self.print(&document(rows));
        }
    }

    /// Prints a document as text, or as Markdown with `--markdown`.
    pub(crate) fn print(self, document: &Document) {
        if self.markdown {
            print!("{}", document.markdown());
        } else {
            print!("{}", document.text());
        }
    }

    /// Prints a report as a table, as Markdown, or as one JSON object.
    pub(crate) fn report<R: serde::Serialize>(self, report: &R, document: fn(&R) -> Document) {
        if self.json {
            println!(
                "{}",
                serde_json::to_string_pretty(report).expect("reports serialise")
            );
        } else {
            self.print(&document(report));
        }
    }
}

/// Where `seam run` puts its pods: one host, or several simulated ones.
#[derive(Debug, clap::Args)]
pub(crate) struct HostsArgs {
    /// Run the pods on this many simulated hosts (for a scene whose clusters name no `host`;
    /// a scene that names them runs on its own hosts without this flag). Pods of one host share
    /// memory (the host's own iceoryx2 prefix); one `seam bridge` per host carries what crosses
    /// hosts over Redis (`--redis`). As root each host is a network namespace made by the run
    /// (and removed after) that reaches Redis only over its veth pair; otherwise the run says
    /// so and uses prefixes alone. Needs `--transport shm`.
    #[arg(long)]
    pub(crate) hosts: Option<u32>,
    /// The Redis server between hosts (on this machine's loopback for simulated hosts).
    #[arg(long, default_value = "redis://127.0.0.1:6379")]
    pub(crate) redis: String,
    /// Simulated latency: delay everything between one host's bridge and Redis by this many ms
    /// each way (a relay in front of Redis; this kernel has no netem).
    #[arg(long, default_value_t = 0.0)]
    pub(crate) delay_ms: f64,
    /// Plus up to this many ms more per chunk, uniformly at random (order kept).
    #[arg(long, default_value_t = 0.0)]
    pub(crate) jitter_ms: f64,
    /// The host whose traffic is delayed (default: the last).
    #[arg(long)]
    pub(crate) delayed_host: Option<String>,
    /// Simulate hosts by iceoryx2 prefix alone, even as root (no network namespaces).
    #[arg(long)]
    pub(crate) no_namespaces: bool,
}

/// Whether `seam ops` frames carry answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum AckMode {
    /// None.
    Off,
    /// One per op of the batch.
    On,
}
