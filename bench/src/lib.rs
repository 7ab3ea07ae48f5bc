//! seam-bench — the `seam` command line and the criterion benches.
//!
//! `seam run` is the main job: a scene's clusters as co-hosted pods, one process each.
//!
//! # Layout
//!
//! - `src/bin/seam/` — the `seam` CLI: `cli.rs` (the commands, clap), `cmd/` (one module per
//!   command: its flags and what it does beyond its library module — progress, printing,
//!   exit status; `cmd/mod.rs` the helpers they share), `main.rs` (dispatch).
//! - [`run`] — `seam run`: starts one pod per cluster of a scene, shows progress, merges their
//!   reports; with `--hosts N`, on simulated hosts (network namespaces as root) with a bridge
//!   each.
//! - [`bridge`] — `seam bridge`: one host's bridge between its shared memory and Redis.
//! - [`relay`] — a TCP relay with a configurable delay (simulated hosts reach Redis through it).
//! - [`network`] — `seam network`: accuracy against a simulated delay between two hosts.
//! - [`chaos`] — `seam chaos`: the pods under faults on a schedule (kills, stops, Redis
//!   restarts, garbage and forged frames) and what survived; a runner over the pods and the
//!   schedule, ops and reports totalled by name from every life's ledger.
//! - [`capacity`] — `seam capacity`: the largest size of a scene each configuration holds at
//!   the rate, plain Rapier (`seam-anchor`, built per row) beside seam's pods.
//! - [`node`] — `seam node`: one pod, ticking on a schedule and sleeping on its transport.
//! - [`accuracy`] — `seam compare`: a split run against its single-world reference, tick by
//!   tick, accuracy and cost of one setting; and the same for free-running pods.
//! - [`record`] — recordings of a run (`--record`): per tick and cluster what it owned, proxied,
//!   applied and was told, in a versioned format; pods' parts merged.
//! - [`inspect`] — `seam inspect`: a recording as a page to scrub through (served live with
//!   `seam run --inspect`), a still PNG, or the page's own timings in headless Chromium.
//! - [`pod`] — one cluster playing its part of a scene (spawns, events, op stage times).
//! - [`sweep`] — `seam sweep`: trials over a grid of settings, `sweep.csv` and charts.
//! - [`ping`] — `seam ping`: one-way latency between two processes over any transport, with
//!   plain iceoryx2 as the floor.
//! - [`ops`] — `seam ops`: routed-op latency between two processes, stage by stage.
//! - [`console`] — stderr: `tracing` logs (`RUST_LOG`) and progress (a bar on a terminal, plain
//!   lines otherwise), logs printed above the bar.
//! - [`redis_server`] — a private `redis-server` child that runs and tests can crash and
//!   restart, and a Redis server's CPU time (`INFO cpu`).
//! - [`throughput`] — `seam throughput`: messages a second through one Redis server and
//!   Redis Clusters of 1 and 3 primaries, with each server's CPU.
//! - [`redis_cluster`] — a private Redis Cluster (`tools/redis-cluster`) that runs and tests
//!   change under load: a primary killed and started again, a slot moved.
//! - [`scene`] — the scene format (`bench/scenes/*.toml`) and its checks.
//! - [`wait`] — spinning or sleeping for the next message ([`wait::WaitMode`]).
//! - [`latency`] — latency recording (hdrhistogram) and percentile summaries.
//! - [`ledger`] — pods' ledgers of every routed op and contact report by name, and following
//!   each name across a run's pods to its end (`seam chaos`).
//! - [`owners`] — who owned each entity at every tick, from the owner lines pods write into
//!   their ledgers (`seam chaos` checks no tick has an entity with no owner or two).
//! - [`error`] — [`error::BenchError`], the one error type of the crate (and
//!   [`error::PingError`]); no `Result<_, String>` anywhere.
//! - [`document`] — reports as data ([`document::Document`]), rendered as text or Markdown.
//! - `benches/` — criterion: `bench_transport` (publish → receive per backend), `bench_sim`
//!   (a tick against raw Rapier, the wire), `bench_proxy` (tick cost with 0 / 1 000 / 10 000
//!   proxies), `bench_replication` (op batches; 10 000 states end to end against the Rapier floor).

pub mod accuracy;
pub mod bridge;
pub mod capacity;
pub mod chaos;
pub mod console;
pub mod document;
pub mod error;
pub mod inspect;
pub mod latency;
pub mod ledger;
pub mod network;
pub mod node;
pub mod ops;
pub mod owners;
pub mod ping;
pub mod pod;
pub mod record;
pub mod redis_cluster;
pub mod redis_server;
pub mod relay;
pub mod run;
pub mod scene;
pub mod sweep;
pub mod throughput;
pub mod wait;
