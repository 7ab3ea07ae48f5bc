//! The report of a run: one summary per pod, totals, and the routed-op stages of all pods.

use seam_proxy::ClusterStats;
use serde::Serialize;

use super::RunPlan;
use super::ownership::Ownership;
use crate::document::{Align::*, Document, Table, grouped};
use crate::latency::{LatencyRecorder, LatencySummary};
use crate::node::{NodeReport, ProxyModeArg, TransportCounts};
use crate::pod::{EventCounts, OpStages, OpStagesSummary};

/// One pod's figures.
#[derive(Debug, Clone, Serialize)]
pub struct PodSummary {
    /// Scene cluster.
    pub cluster: String,
    /// Ticks run.
    pub ticks: u64,
    /// Time each tick took, ns.
    pub tick_time: LatencySummary,
    /// CPU time the pod's thread spent in each tick, ns.
    pub tick_cpu: LatencySummary,
    /// Ticks longer than the tick period.
    pub overruns: u64,
    /// Largest delay of a tick's start behind schedule, ns.
    pub max_lag_ns: u64,
    /// How late the pod was for the shared start, ns.
    pub start_late_ns: u64,
    /// Entities spawned at the start.
    pub entities_at_start: usize,
    /// Entities owned at the end.
    pub entities_owned: usize,
    /// Proxies at the end.
    pub proxies: usize,
    /// Most proxies seen.
    pub proxies_peak: usize,
    /// The cluster's counters.
    pub cluster_stats: ClusterStats,
    /// The transport's counters.
    pub transport_stats: TransportCounts,
    /// What the scripted events did.
    pub events: EventCounts,
    /// Routed ops this pod applied.
    pub ops: OpStagesSummary,
    /// Mean thread CPU time per tick of each phase, ms, in the order a tick runs them.
    pub phases_ms: Vec<(String, f64)>,
    /// Rapier's narrow phase, averaged over samples: how many pairs involve proxies.
    pub pairs: crate::node::CensusMean,
    /// Time its recorder took each tick, ns (with `--record`; part of `tick_time`).
    pub record_time: Option<LatencySummary>,
    /// Bytes it recorded.
    pub recorded_bytes: u64,
}

/// Sums over all pods.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Totals {
    /// Entities spawned at the start plus projectiles fired.
    pub entities_expected: usize,
    /// Entities owned at the end.
    pub entities_owned: usize,
    /// The pods' counters, summed (`ClusterStats::ops_dropped` and `frames_refused` sum their
    /// reasons).
    pub cluster: ClusterStats,
    /// Messages lost to full receive buffers.
    pub overflow_drops: u64,
    /// Frames refused: foreign or corrupted messages the transport dropped, and every frame a
    /// pod refused (`ClusterStats::frames_refused`).
    pub malformed: u64,
    /// Tick overruns.
    pub overruns: u64,
}

/// Everything `seam run` prints.
#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    /// Scene name.
    pub scene: String,
    /// Entities the scene spawns at the start.
    pub entities: u64,
    /// Transport URL, password hidden.
    pub transport: String,
    /// Ticks per second (0: as fast as possible).
    pub rate_hz: f64,
    /// How neighbour entities were modelled.
    pub proxy_mode: ProxyModeArg,
    /// A replication frame every this many ticks.
    pub replication_interval: u64,
    /// Whether contacts pushed across the seam (see `ClusterConfig::coupling`).
    pub coupling: bool,
    /// Whether routed ops were exchanged before the step (see `ClusterConfig::exchange`).
    pub exchange: bool,
    /// Whether replication states were quantized.
    pub quantize: bool,
    /// Seconds from launch to the last pod's exit.
    pub wall_s: f64,
    /// One entry per pod.
    pub pods: Vec<PodSummary>,
    /// Sums over the pods.
    pub totals: Totals,
    /// Stages of every routed op applied in the run.
    pub ops: OpStagesSummary,
    /// Whether every entity ended with exactly one owner.
    pub ownership: Ownership,
    /// CPU the Redis server used during the run, s (runs on Redis, or on several hosts).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub redis_cpu_s: Option<f64>,
    /// The hosts of a run on several, and their bridges.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hosts: Option<super::HostsSummary>,
}

impl RunReport {
    /// Merges the pods' reports.
    pub(super) fn new(
        scene: &crate::scene::Scene,
        transport: String,
        plan: &RunPlan,
        wall_s: f64,
        reports: &[NodeReport],
    ) -> Self {
        let mut all_ops = OpStages::default();
        let mut totals = Totals::default();
        let mut pods = Vec::new();
        for r in reports {
            all_ops.merge(&r.ops);
            let s = &r.cluster_stats;
            totals.entities_expected += r.entities_at_start + r.events.projectiles as usize;
            totals.entities_owned += r.entities_owned;
            totals.cluster += s;
            totals.overflow_drops += r.transport_stats.overflow_drops;
            totals.malformed += r.transport_stats.malformed_drops + s.frames_refused();
            totals.overruns += r.overruns;
            pods.push(PodSummary {
                cluster: r.cluster.clone(),
                ticks: r.ticks,
                tick_time: r.tick_time.summary(),
                tick_cpu: r.tick_cpu.summary(),
                overruns: r.overruns,
                max_lag_ns: r.max_lag_ns,
                start_late_ns: r.start_late_ns,
                entities_at_start: r.entities_at_start,
                entities_owned: r.entities_owned,
                proxies: r.proxies,
                proxies_peak: r.proxies_peak,
                cluster_stats: r.cluster_stats,
                transport_stats: r.transport_stats,
                events: r.events,
                ops: r.ops.summary(),
                phases_ms: (r.phases.means().into_iter())
                    .map(|(phase, ns)| (phase, ns / 1e6))
                    .collect(),
                pairs: r.phases.census_mean(),
                record_time: r.record_time.as_ref().map(LatencyRecorder::summary),
                recorded_bytes: r.recorded_bytes,
            });
        }
        Self {
            scene: scene.name.clone(),
            entities: scene.entity_count(),
            transport,
            rate_hz: plan.rate,
            proxy_mode: plan.proxy_mode,
            replication_interval: plan.replication_interval,
            coupling: plan.coupling,
            exchange: plan.exchange,
            quantize: plan.quantize,
            wall_s,
            pods,
            totals,
            ops: all_ops.summary(),
            ownership: super::ownership::check(scene, &plan.run_id, reports),
            redis_cpu_s: None,
            hosts: None,
        }
    }
}

/// What `seam run` reports (as text, or as BENCHMARKS.md quotes it with `--markdown`): the
/// run, a row per pod, what the pods published, the stages of every routed op applied, the
/// hosts and bridges if there were several, the totals, and whether every entity ended owned
/// by exactly one pod.
pub fn document(report: &RunReport) -> Document {
    let mut doc = Document::new();
    doc.line(title(report));
    doc.line("");
    doc.table(pods_table(report));
    doc.line(
        "tick times in ms; overruns = ticks longer than the tick period; contacts = with \
         proxies, sent to their owner and received; lost = messages lost to a full buffer; \
         refused = frames refused (undecodable, other version, wrong sender, replayed, \
         implausible tick)",
    );
    doc.line(bytes_line(report));
    if report.pods.iter().any(|p| !p.phases_ms.is_empty()) {
        doc.line("");
        doc.table(super::phases::phases_table(report));
        doc.line(super::phases::PHASES_NOTE);
    }
    let recording = recording_line(report);
    if !recording.is_empty() {
        doc.line(recording);
    }
    if report.ops.ops > 0 {
        doc.line("");
        doc.table(stages_table(report));
        let t = &report.ops.ticks;
        doc.line(format!(
            "whole in ticks (applied tick − issued tick): p50 {}, p99 {}, p99.9 {}, max {}",
            t.p50, t.p99, t.p999, t.max
        ));
    } else {
        doc.line("routed ops applied: 0");
    }
    if let Some(hosts) = &report.hosts {
        doc.line("");
        doc.line(format!("Hosts simulated as {}.", hosts.simulated_as));
        doc.table(bridges_table(report, hosts));
        doc.table(crossing_table(hosts));
    }
    doc.line("");
    doc.line(totals_lines(report));
    doc
}

fn title(report: &RunReport) -> String {
    let ticks = report.pods.iter().map(|p| p.ticks).max().unwrap_or(0);
    let rate = if report.rate_hz > 0.0 {
        format!("at {} Hz", report.rate_hz)
    } else {
        "as fast as possible".to_owned()
    };
    format!(
        "seam run: {} ({} entities) on {}, {} pods, {ticks} ticks {rate}, {:?} proxies, \
         replication every {} tick(s){}, coupling {}, ops {}, {:.1} s",
        report.scene,
        report.entities,
        report.transport,
        report.pods.len(),
        report.proxy_mode,
        report.replication_interval,
        if report.quantize { " quantized" } else { "" },
        if report.coupling { "on" } else { "off" },
        if report.exchange {
            "exchanged before the step"
        } else {
            "after the step"
        },
        report.wall_s
    )
}

/// A row per pod.
fn pods_table(report: &RunReport) -> Table {
    let transport = transport_name(&report.transport);
    let mut pods = Table::new(&[
        ("transport", Left),
        ("pod", Left),
        ("ticks", Right),
        ("tick p50 ms", Right),
        ("p99", Right),
        ("p99.9", Right),
        ("max", Right),
        ("overruns", Right),
        ("owned", Right),
        ("proxies", Right),
        ("ops routed", Right),
        ("ops applied", Right),
        ("ops dropped", Right),
        ("contacts sent", Right),
        ("contacts received", Right),
        ("hand-offs out", Right),
        ("in", Right),
        ("lost", Right),
        ("refused", Right),
    ]);
    for p in &report.pods {
        let (t, s) = (&p.tick_time, &p.cluster_stats);
        pods.row(vec![
            transport.clone(),
            p.cluster.clone(),
            grouped(p.ticks),
            millis(t.p50_ns),
            millis(t.p99_ns),
            millis(t.p999_ns),
            millis(t.max_ns),
            grouped(p.overruns),
            grouped(p.entities_owned as u64),
            grouped(p.proxies as u64),
            grouped(s.ops_routed),
            grouped(s.ops_applied),
            grouped(s.ops_dropped()),
            grouped(s.contacts_sent),
            grouped(s.contacts_received),
            grouped(s.handoffs_out),
            grouped(s.handoffs_in),
            grouped(p.transport_stats.overflow_drops),
            grouped(p.transport_stats.malformed_drops + s.frames_refused()),
        ]);
    }
    pods
}

/// The stages of every routed op applied, all pods merged, in µs and (the p50) in ticks.
fn stages_table(report: &RunReport) -> Table {
    let o = &report.ops;
    let period_ns = (report.rate_hz > 0.0).then(|| 1e9 / report.rate_hz);
    let mut stages = Table::new(&[
        ("transport", Left),
        ("ops", Right),
        ("stage", Left),
        ("p50", Right),
        ("p99", Right),
        ("p99.9", Right),
        ("max", Right),
        ("p50 in ticks", Right),
    ]);
    let us = |ns: u64| grouped((ns as f64 / 1000.0).round() as u64);
    for (i, (name, s)) in [
        ("queue", &o.queue),
        ("transport", &o.transport),
        ("apply", &o.apply),
        ("whole", &o.whole),
    ]
    .into_iter()
    .enumerate()
    {
        stages.row(vec![
            transport_name(&report.transport),
            if i == 0 {
                grouped(o.ops)
            } else {
                String::new()
            },
            name.to_owned(),
            us(s.p50_ns),
            us(s.p99_ns),
            us(s.p999_ns),
            us(s.max_ns),
            period_ns.map_or("-".to_owned(), |p| format!("{:.3}", s.p50_ns as f64 / p)),
        ]);
    }
    stages
}

/// What each host's bridge carried.
fn bridges_table(report: &RunReport, hosts: &super::HostsSummary) -> Table {
    let mut bridges = Table::new(&[
        ("host", Left),
        ("pods", Left),
        ("messages out", Right),
        ("MB out", Right),
        ("messages in", Right),
        ("MB in", Right),
        ("refused", Right),
        ("bridge CPU % of a core", Right),
    ]);
    for bridge in &hosts.bridges {
        let pods: Vec<&str> = report
            .pods
            .iter()
            .zip(&hosts.layout)
            .filter(|(_, h)| **h == bridge.host)
            .map(|(p, _)| p.cluster.as_str())
            .collect();
        bridges.row(vec![
            bridge.host.clone(),
            pods.join(", "),
            grouped(bridge.out.messages),
            format!("{:.1}", bridge.out.bytes as f64 / 1e6),
            grouped(bridge.into.messages),
            format!("{:.1}", bridge.into.bytes as f64 / 1e6),
            grouped(bridge.out.refused + bridge.into.refused),
            format!("{:.1}", 100.0 * bridge.core_share()),
        ]);
    }
    bridges
}

/// Routed ops on one host against those that crossed hosts.
fn crossing_table(hosts: &super::HostsSummary) -> Table {
    let mut crossing = Table::new(&[
        ("routed ops", Left),
        ("ops", Right),
        ("transport p50 µs", Right),
        ("p99", Right),
        ("whole p50 µs", Right),
    ]);
    let us = |ns: u64| grouped((ns as f64 / 1000.0).round() as u64);
    for (name, ops) in [
        ("on one host", &hosts.ops_same_host),
        ("across hosts", &hosts.ops_cross_host),
    ] {
        if let Some(o) = ops {
            crossing.row(vec![
                name.to_owned(),
                grouped(o.ops),
                us(o.transport.p50_ns),
                us(o.transport.p99_ns),
                us(o.whole.p50_ns),
            ]);
        }
    }
    crossing
}

/// The totals, outages, the Redis server's CPU, and the ownership check.
fn totals_lines(report: &RunReport) -> String {
    let t = &report.totals;
    let c = &t.cluster;
    let mut out = format!(
        "entities: {} expected (spawned + fired), {} owned at the end; ops routed {}, applied {}, \
         forwarded {}, dropped {}; contacts {} sent, {} received; hand-offs {} out ({} by the \
         authority policy, {:.1} a second), {} in; overruns {}; neighbours taken for dead {}\n",
        t.entities_expected,
        t.entities_owned,
        c.ops_routed,
        c.ops_applied,
        c.ops_forwarded,
        c.ops_dropped(),
        c.contacts_sent,
        c.contacts_received,
        c.handoffs_out,
        c.handoffs_by_policy,
        c.handoffs_out as f64 / report.wall_s.max(1e-9),
        c.handoffs_in,
        t.overruns,
        c.neighbours_lost
    );
    for p in report
        .pods
        .iter()
        .filter(|p| p.transport_stats.disconnects > 0)
    {
        let t = &p.transport_stats;
        out += &format!(
            "outage: {} lost its server {} time(s), reconnected {}, {:.2} s down, {} publishes \
             dropped\n",
            p.cluster,
            t.disconnects,
            t.reconnects,
            t.down_ns as f64 / 1e9,
            t.dropped_while_down
        );
    }
    if let Some(cpu) = report.redis_cpu_s {
        out += &format!(
            "Redis server: {cpu:.2} s of CPU over the run's {:.1} s ({:.1} % of a core)\n",
            report.wall_s,
            100.0 * cpu / report.wall_s.max(1e-9)
        );
    }
    let o = &report.ownership;
    out += &format!(
        "ownership: {} entities expected, {} owned by exactly one pod, {} lost, {} owned twice{}",
        o.expected,
        o.owned_once,
        o.lost.len(),
        o.duplicated.len(),
        if o.holds() {
            String::new()
        } else {
            format!("  <-- FAILED: {}", o.names.join(", "))
        }
    );
    out
}

fn millis(nanos: u64) -> String {
    format!("{:.2}", nanos as f64 / 1e6)
}

/// What the pods published a tick, all pods summed: replication frames, and events frames
/// (routed ops, their answers, contacts, seam impulses).
fn bytes_line(report: &RunReport) -> String {
    let ticks = report
        .pods
        .iter()
        .map(|p| p.ticks)
        .max()
        .unwrap_or(0)
        .max(1) as f64;
    let sum = |f: fn(&seam_proxy::ClusterStats) -> u64| {
        report.pods.iter().map(|p| f(&p.cluster_stats)).sum::<u64>() as f64
    };
    let replication = sum(|s| s.replication_bytes);
    let events = sum(|s| s.events_bytes);
    format!(
        "published a tick, all pods: {:.1} kB replication + {:.2} kB events = {:.1} kB\n",
        replication / ticks / 1e3,
        events / ticks / 1e3,
        (replication + events) / ticks / 1e3
    )
}

/// What recording cost each pod a tick, if the pods recorded (empty otherwise).
fn recording_line(report: &RunReport) -> String {
    let costs: Vec<String> = report
        .pods
        .iter()
        .filter_map(|p| {
            let r = p.record_time.as_ref()?;
            let share = r.p50_ns as f64 / p.tick_time.p50_ns.max(1) as f64 * 100.0;
            Some(format!(
                "{} {:.3} ms ({share:.1} %)",
                p.cluster,
                r.p50_ns as f64 / 1e6
            ))
        })
        .collect();
    if costs.is_empty() {
        return String::new();
    }
    let bytes: u64 = report.pods.iter().map(|p| p.recorded_bytes).sum();
    format!(
        "\nrecording, per pod p50 a tick (share of its tick p50): {}; {:.1} MB written\n",
        costs.join(", "),
        bytes as f64 / 1e6
    )
}

/// `shm`, `redis` or `local` for a transport URL.
fn transport_name(url: &str) -> String {
    url.split(['?', ':']).next().unwrap_or(url).to_owned()
}
