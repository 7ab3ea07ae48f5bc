//! What a pod reports: progress lines and its final report.

use std::fmt;

use seam_proxy::ClusterStats;
use seam_sim::wire::{ClusterId, EntityId};
use serde::{Deserialize, Serialize};

use crate::latency::{LatencyRecorder, micros};
use crate::pod::{EventCounts, OpStages};

/// One JSON line a pod writes on stdout.
#[derive(Clone, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NodeLine {
    /// Four times a second.
    Progress(Box<NodeProgress>),
    /// Once, at the end.
    Report(Box<NodeReport>),
}

/// Where a pod is.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct NodeProgress {
    /// Scene cluster.
    pub cluster: String,
    /// Ticks done.
    pub tick: u64,
    /// Ticks planned.
    pub ticks: u64,
    /// p99 of tick time so far, ns.
    pub tick_p99_ns: u64,
    /// Ticks that took longer than the tick period.
    pub overruns: u64,
    /// Entities owned now.
    pub entities_owned: usize,
    /// Proxies now.
    pub proxies: usize,
    /// The cluster's counters so far (a pod that is killed leaves these behind).
    pub cluster_stats: ClusterStats,
    /// The transport's counters so far.
    pub transport_stats: TransportCounts,
    /// Resident memory of the pod's process, KiB.
    pub rss_kib: u64,
    /// Routed ops sent and not answered yet (`Cluster::ops_unanswered`).
    #[serde(default)]
    pub ops_unanswered: u64,
    /// Contact reports sent and not answered yet (`Cluster::contacts_unanswered`).
    #[serde(default)]
    pub contacts_unanswered: u64,
}

impl fmt::Display for NodeProgress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {}/{} tick p99 {} ms, {} overruns, {} owned, {} proxies",
            self.cluster,
            self.tick,
            self.ticks,
            micros(self.tick_p99_ns / 1000),
            self.overruns,
            self.entities_owned,
            self.proxies
        )
    }
}

/// A transport's counters.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct TransportCounts {
    /// Messages published.
    pub published: u64,
    /// Messages received.
    pub received: u64,
    /// Messages lost to a full receive buffer.
    pub overflow_drops: u64,
    /// Foreign or corrupted messages skipped.
    pub malformed_drops: u64,
    /// Connections to a server lost.
    pub disconnects: u64,
    /// Connections re-established.
    pub reconnects: u64,
    /// Time without a server, ns.
    pub down_ns: u64,
    /// Publishes dropped without a server.
    pub dropped_while_down: u64,
    /// Messages without a tag dropped by a transport with a frame key.
    #[serde(default)]
    pub untagged_drops: u64,
    /// Messages with a wrong tag dropped by a transport with a frame key.
    #[serde(default)]
    pub bad_tag_drops: u64,
    /// Messages without a signature dropped by a transport with a keyring.
    #[serde(default)]
    pub unsigned_drops: u64,
    /// Messages no trusted signer signed, dropped by a transport with a keyring.
    #[serde(default)]
    pub forged_drops: u64,
}

impl From<seam_transport::Stats> for TransportCounts {
    fn from(s: seam_transport::Stats) -> Self {
        Self {
            published: s.published,
            received: s.received,
            overflow_drops: s.overflow_drops,
            malformed_drops: s.malformed_drops,
            disconnects: s.disconnects,
            reconnects: s.reconnects,
            down_ns: s.down_ns,
            dropped_while_down: s.dropped_while_down,
            untagged_drops: s.untagged_drops,
            bad_tag_drops: s.bad_tag_drops,
            unsigned_drops: s.unsigned_drops,
            forged_drops: s.forged_drops,
        }
    }
}

/// Everything one pod measured.
#[derive(Clone, Serialize, Deserialize)]
pub struct NodeReport {
    /// Scene cluster (`reference` for a reference pod).
    pub cluster: String,
    /// Its id in this run.
    pub cluster_id: String,
    /// Transport URL, password hidden.
    pub transport: String,
    /// Ticks per second asked for (0: as fast as possible).
    pub rate_hz: f64,
    /// Ticks run.
    pub ticks: u64,
    /// The world tick it started at (0, or where a pod restarted with `--rejoin` joined).
    pub first_tick: u64,
    /// Ticks planned.
    pub ticks_planned: u64,
    /// Stopped by SIGINT or SIGTERM before the planned ticks.
    pub stopped_by_signal: bool,
    /// Seconds from the first tick's schedule to the end.
    pub wall_s: f64,
    /// How late the pod was for the shared start time, ns.
    pub start_late_ns: u64,
    /// Time each tick took, ns.
    pub tick_time: LatencyRecorder,
    /// CPU time the pod's thread spent in each tick, ns: its work, apart from waiting for a
    /// core that another process holds.
    #[serde(default)]
    pub tick_cpu: LatencyRecorder,
    /// Thread CPU time per tick by phase, and Rapier's narrow phase sampled every
    /// [`CENSUS_EVERY`](super::CENSUS_EVERY) ticks.
    #[serde(default)]
    pub phases: super::PhaseTally,
    /// Ticks that took longer than the tick period.
    pub overruns: u64,
    /// Largest delay of a tick's start behind its schedule, ns.
    pub max_lag_ns: u64,
    /// Entities spawned at the start.
    pub entities_at_start: usize,
    /// Entities owned at the end.
    pub entities_owned: usize,
    /// Proxies at the end.
    pub proxies: usize,
    /// Most proxies seen at a progress point.
    pub proxies_peak: usize,
    /// The cluster's counters.
    pub cluster_stats: ClusterStats,
    /// The transport's counters.
    pub transport_stats: TransportCounts,
    /// What the scripted events did.
    pub events: EventCounts,
    /// Stage times of the routed ops this pod applied.
    pub ops: OpStages,
    /// The same, by the scene cluster whose frame brought them.
    #[serde(default)]
    pub ops_by_sender: Vec<(String, OpStages)>,
    /// Contacts that started between a projectile and anything in this pod's world: pair →
    /// first tick.
    pub projectile_hits: Vec<((EntityId, EntityId), u64)>,
    /// Where each dynamic body this pod simulates ended (projectiles left out).
    pub final_positions: Vec<(EntityId, [f32; 3])>,
    /// Every entity this pod owned at the end.
    pub owned: Vec<EntityId>,
    /// Every neighbour entity this pod held a proxy of at the end, with the owner it named:
    /// where a lost entity was last seen.
    #[serde(default)]
    pub proxied: Vec<(EntityId, ClusterId)>,
    /// Every projectile that was ever in this pod's world (owned or as a proxy), as seen every
    /// few ticks.
    pub projectiles_seen: Vec<EntityId>,
    /// Authority flips of dynamic bodies this pod took part in (with `--track-flips`).
    #[serde(default)]
    pub flips: Vec<crate::pod::FlipRecord>,
    /// Bytes of recording written (with `--record`).
    #[serde(default)]
    pub recorded_bytes: u64,
    /// Owned entity-ticks recorded (with `--record`).
    #[serde(default)]
    pub recorded_entity_ticks: u64,
    /// Time the recorder took each tick, ns (with `--record`; included in `tick_time`).
    #[serde(default)]
    pub record_time: Option<LatencyRecorder>,
    /// Resident memory at the end, KiB.
    pub rss_kib: u64,
    /// Routed ops sent and not answered yet (`Cluster::ops_unanswered`).
    #[serde(default)]
    pub ops_unanswered: u64,
    /// Contact reports sent and not answered yet (`Cluster::contacts_unanswered`).
    #[serde(default)]
    pub contacts_unanswered: u64,
}
