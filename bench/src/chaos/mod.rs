//! `seam chaos`: a scene's pods under faults on a schedule, and what survived.
//!
//! The pods run as in `seam run` (one `seam node` per cluster, in phase on a shared schedule) on a
//! transport of their own: shared memory under a private prefix, with `--transport redis` a
//! private `redis-server` this command starts (so it can kill it), or with `--transport
//! redis-cluster` a private Redis Cluster (`tools/redis-cluster`: three primaries, three
//! replicas). Every `fault_every` one fault, in turn:
//!
//! 1. **kill** a pod with SIGKILL and start it again 2 s later with `--rejoin` (empty, at the
//!    world's tick; its neighbours adopted what it owned and hand it back);
//! 2. **restart Redis** (SIGKILL, 1 s down, started again on the same port), with Redis only;
//!    on a Redis Cluster, **kill a primary**: the one serving a random pod's replication
//!    channel, with SIGKILL, started again 3 s later (its replica was promoted meanwhile; it
//!    rejoins as a replica);
//! 3. **stop** a pod with SIGSTOP for 1 s, then SIGCONT;
//! 4. on a Redis Cluster, **move a slot**: that of a random pod's replication channel, to
//!    another primary, live (the steps of `redis-cli --cluster reshard` for one slot).
//!
//! On a Redis Cluster the turn is kill, move a slot, stop, kill a primary.
//!
//! Kills happen in the first half of the run only (the others go on to the end), so every pod's
//! last incarnation lives at least half the run and its memory after warm-up can be judged. No
//! fault starts in the last 9 s, so the run ends calm.
//!
//! Between faults, every 250 ms, bursts of garbage and forged frames go into every channel
//! ([`Injector`]); none in the second before a fault or in the second after every pod ran again
//! after one (a pod stopped mid-command may drop its connection on waking, and with it what
//! was in its socket), and a due fault waits (up to 2 s) until the
//! pods' latest counters account for every injected frame delivered so far, so none is still in
//! a socket or in the server when a pod is killed or stopped or Redis restarted. Should some be
//! unaccounted for when the fault fires anyway, the report names the faults between which they
//! went unseen. A fault is *survived* when every pod has shown
//! progress again within 5 s of its end. At the end: faults by kind, injected frames against
//! the pods' refusal counters, entities lost or owned twice, ops and frames dropped by reason,
//! adoption, outages, panics, and each pod's memory after warm-up. Every pod life writes a
//! ledger (`seam node --ledger`), and every routed op and contact report is followed by name
//! across them ([`crate::ledger::follow`]): the sums of the pods' counters cannot tell an op
//! applied twice, nor one lost behind another counted twice; the names can.
//!
//! The run fails (see [`ChaosReport::holds`]) on anything chaos did not cause: a pod found
//! dead when it was picked for a kill, a pod that ended badly or sent no report, a panic on a
//! pod's stderr (counted after every reader has read to the end); and when a planned fault
//! kind was never injected, when the run outlives its deadline (the pods are then killed), when
//! adoptions and returns do not balance, when an op or report is lost or applied twice (by the
//! sums or by name), or when a pod's memory grows past its bound.

mod broker;
mod inject;
mod pods;
mod report;
mod runner;
mod schedule;

use std::ffi::OsString;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use crate::error::BenchResult;
pub use broker::Broker;
pub use inject::{InjectCounts, Injector};
pub use report::{
    ChaosReport, FaultCounts, FrameCounts, MEMORY_BOUND_PCT, MemoryRow, MemorySample, OpCounts,
    RecoveryCounts, document,
};
use runner::Runner;
pub(crate) use schedule::Fault;

/// What `seam chaos` runs.
pub struct ChaosPlan {
    /// The scene file.
    pub scene: PathBuf,
    /// What carries the frames: shared memory, or a private Redis server or Redis Cluster.
    pub broker: Broker,
    /// Ticks per second.
    pub rate: f64,
    /// How long the pods run.
    pub duration: Duration,
    /// Time from the end of one fault to the start of the next.
    pub fault_every: Duration,
    /// Copies of every grid entity stacked along y.
    pub layers: u32,
    /// Seeds which pod each fault hits and the garbage.
    pub seed: u64,
    /// The command that starts a pod, before its flags: `[seam, "node"]`.
    pub node_command: Vec<OsString>,
    /// A frame key for the pods (`key=` in their URL); the injector has none, so everything
    /// it sends must be refused as untagged.
    pub key: Option<String>,
    /// Pods record their streams into part files here (see [`crate::record`]).
    pub record_dir: Option<PathBuf>,
}

/// Runs the plan; `progress` gets a line about once a second.
pub fn run(
    plan: &ChaosPlan,
    stop: &AtomicBool,
    mut progress: impl FnMut(&str),
) -> BenchResult<ChaosReport> {
    let mut runner = Runner::start(plan)?;
    while runner.step(stop, &mut progress)? {}
    runner.finish()
}
