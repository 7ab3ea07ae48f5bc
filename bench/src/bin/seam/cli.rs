//! `seam`'s command line: the commands, each with its help; each command's flags are in its
//! module under `cmd/`.

use clap::{Parser, Subcommand};
use seam_bench::bridge::BridgeArgs;
use seam_bench::document::Document;
use seam_bench::node::NodeArgs;

use crate::cmd::{
    capacity, chaos, compare, inspect, keys, network, ops, ping, run, scene, sweep, throughput,
};

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
    /// and received, hand-offs and drops; where each pod's thread CPU went, phase by phase
    /// (receive, reconcile, user, settle, exchange, couple, step, report, publish), and how
    /// many of Rapier's pairs and contacts involve proxies; and for all pods the routed-op
    /// stages (queue, transport, apply, whole) in µs and ticks. Ctrl-C stops the pods, which
    /// still report.
    Run(run::RunArgs),
    /// Compare one setting against the single-world reference: accuracy and cost.
    ///
    /// Runs each scene split over its clusters in lock-step (in this process, on iceoryx2's
    /// in-process transport) and as one world owning everything, tick for tick, and prints
    /// position and orientation error (and the body furthest off), projectile hit recall and
    /// precision, momentum error, hand-offs and their jumps, bodies with two owners or none,
    /// bodies that escaped (fell through or flew off where the single world's did not), and the
    /// split run's tick time (per cluster and summed, against the single world's), bytes per
    /// tick, proxies and op delay. Beside the error stands the noise floor: the single world
    /// run again three times, each with its bodies inserted in reverse order and each dynamic
    /// one moved 1 µm in a direction of its own, judged the same way, the farthest of the
    /// three; and for split and floor the onset (the first tick a body is 2 cm off). The
    /// "against the floor" line says whether the split is within it. `--markdown` prints one
    /// table row per scene.
    Compare(compare::CompareArgs),
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
    Sweep(sweep::SweepArgs),
    /// Accuracy against the network between hosts: each scene on two simulated hosts, the second
    /// host's traffic to Redis delayed by each delay in turn.
    ///
    /// Pods run free-running at `--rate` as in `seam run --hosts 2` (network namespaces as root,
    /// else separate shm prefixes; a relay in front of Redis adds the delay, since this kernel
    /// has no netem: the delay is simulated). Each run is compared with a single-world run of
    /// the same ticks: projectile hit recall, final position error, routed-op delay in ticks.
    /// Writes `network.csv` and `accuracy_vs_delay_SCENE.svg`/`.png` into `--out`.
    Network(network::NetworkArgs),
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
    Chaos(chaos::ChaosArgs),
    /// The largest size of a scene that holds the tick rate: plain Rapier against seam's pods.
    ///
    /// For each row — plain Rapier on one thread (`rapier`, `rapier-ed`), Rapier's `parallel`
    /// feature on every core (`parallel`, `parallel-ed`), N plain worlds side by side, each one
    /// part of the scene cut as seam:N cuts it with nothing crossing between them (`apart:N`:
    /// the most any split over N processes could hold here), seam as N pods on shared memory
    /// (`seam:N`; the scene's own clusters when it has N, else its world cut into N) — finds
    /// by doubling and bisection the most layers (every grid entity repeated along y) at which
    /// at most `--max-overrun` of the ticks take longer than the period in every pod (every
    /// world apart) on its own, each probe running
    /// `--ticks` ticks paced at `--rate`. Every row leaves out the scene's scripted events,
    /// which plain Rapier has no way to run. Plain Rapier runs as `seam-anchor`, built on first
    /// use with exactly the features its row names (cargo is needed). Prints one line per
    /// probe, then per row the largest size and its bodies against the first row's, wall and
    /// CPU time per tick (seam: the slowest pod's wall, the pods' thread CPU summed, so
    /// contention shows apart from work), and CPU at the first row's largest size against
    /// the first row's; then, for seam's rows there, each phase's thread CPU summed over the
    /// pods and the share of Rapier's pairs and contacts with a proxy; writes
    /// OUT/capacity_SCENE.svg and .png.
    Capacity(capacity::CapacityArgs),
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
    Inspect(inspect::InspectArgs),
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
    Bridge(BridgeArgs),
    /// Measure one-way latency between two processes (round trip / 2) over each transport.
    ///
    /// Spawns a peer process that echoes every message back, times the round trips and prints
    /// p50 / p99 / p99.9 / max one-way latency and messages per second per transport and size.
    /// Beside each `shm` row it measures plain iceoryx2 (no seam layer, busy-polling) as the
    /// floor, and prints the shm / iceoryx2 and redis / shm ratios of one run.
    Ping(ping::PingArgs),
    /// Make per-cluster signing keys and the keyring that checks them.
    ///
    /// With `sign_key=ID.key` in its transport URL a pod signs every message it publishes
    /// (ed25519); with `keyring=keyring` a pod drops, and counts, any message no cluster of
    /// the keyring signed, and refuses a frame whose claimed sender is not its signer — so a
    /// pod holding one cluster's key cannot speak for another. Works on every backend and
    /// through bridges. Prints the URL settings for each cluster.
    Keys(keys::KeysArgs),
    /// Measure messages a second through one Redis server and through Redis Clusters.
    ///
    /// Makes each target itself (a private redis-server; private clusters of 1 and 3 primaries
    /// made by tools/redis-cluster), offers it fixed loads (publisher threads, each with its
    /// own transport, over channels spread across the cluster's slots; subscriber threads on
    /// every channel), and prints per load the messages published and delivered a second and
    /// the busiest and mean primary's CPU, with the largest load each target carried.
    Throughput(throughput::ThroughputArgs),
    /// Measure routed-op latency between two processes, stage by stage, per transport.
    ///
    /// This process issues batches of impulses on an entity a child process owns, as real
    /// physics-events frames; the owner applies each frame as soon as it arrives (no tick wait)
    /// and acknowledges it. Stamps on the host monotonic clock give each op's stages: queue
    /// (issued → published), transport (published → received), apply (received → applied) and
    /// the whole. Prints p50 / p99 / p99.9 per stage and ops per second, and the redis / shm
    /// ratio of the transport stage.
    Ops(ops::OpsArgs),
    /// Check scene files and summarise them (clusters, entities, events, ticks).
    ///
    /// A bad file is reported as FILE:LINE:COLUMN with the field and what is wrong. The format
    /// is described in `bench/src/scene/mod.rs`; `bench/scenes/` has one scene per class of
    /// problem (the scene table of docs/accuracy.md).
    Scene(scene::SceneArgs),
    /// The owning side of `seam ops` (started by it).
    #[command(hide = true)]
    OpsOwner(ops::OwnerArgs),
    /// The peer side of `seam ping` (started by it).
    #[command(hide = true)]
    PingPeer(ping::PeerArgs),
    /// The peer side of the plain-iceoryx2 floor (started by `seam ping`).
    #[command(hide = true)]
    PingFloorPeer(ping::FloorPeerArgs),
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
