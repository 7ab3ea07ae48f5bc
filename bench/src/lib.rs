//! seam-bench — the `seam` command line and the criterion benches.
//!
//! `seam ping` is here now; pods, scenes, op latency and sweeps join it as the layers above the
//! transport land.
//!
//! # Layout
//!
//! - `src/main.rs` — the `seam` CLI (clap): subcommands and their flags.
//! - [`ping`] — `seam ping`: one-way latency between two processes over any transport, with
//!   plain iceoryx2 as the floor.
//! - [`ops`] — `seam ops`: routed-op latency between two processes, stage by stage.
//! - [`scene`] — the scene format (`bench/scenes/*.toml`) and its checks.
//! - [`wait`] — spinning or sleeping for the next message ([`wait::WaitMode`]).
//! - [`latency`] — latency recording (hdrhistogram) and percentile summaries.
//! - `benches/bench_transport.rs` — in-process publish → receive per backend (criterion).

pub mod latency;
pub mod ops;
pub mod ping;
pub mod scene;
pub mod wait;
