//! Routed-op stage times, recorded by the owner that applied each op.

use seam_proxy::OpTiming;
use serde::{Deserialize, Serialize};

use crate::latency::{LatencyRecorder, LatencySummary};

/// Histograms of the stages of routed ops (ns), and of the whole in ticks; mergeable across
/// pods.
#[derive(Clone, Default, Serialize, Deserialize)]
pub struct OpStages {
    /// Ops recorded.
    pub ops: u64,
    /// issued → applied.
    pub whole: LatencyRecorder,
    /// issued → published: waiting in the issuing cluster for its tick to publish.
    pub queue: LatencyRecorder,
    /// published → received: the transport.
    pub transport: LatencyRecorder,
    /// received → applied: waiting in the owner for its next tick.
    pub apply: LatencyRecorder,
    /// The owner's tick at apply minus the issuer's tick at the write.
    pub tick_delay: LatencyRecorder,
}

/// Percentiles of the whole delay of routed ops, in ticks.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct TickDelaySummary {
    /// Median.
    pub p50: u64,
    /// 99th percentile.
    pub p99: u64,
    /// 99.9th percentile.
    pub p999: u64,
    /// Largest.
    pub max: u64,
}

/// Percentiles of every stage.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct OpStagesSummary {
    /// Ops recorded.
    pub ops: u64,
    /// issued → applied.
    pub whole: LatencySummary,
    /// issued → published.
    pub queue: LatencySummary,
    /// published → received.
    pub transport: LatencySummary,
    /// received → applied.
    pub apply: LatencySummary,
    /// Applied tick minus issued tick.
    pub ticks: TickDelaySummary,
}

impl OpStages {
    /// Records one applied op.
    pub fn record(&mut self, timing: &OpTiming) {
        let span = |from: u64, to: u64| to.saturating_sub(from);
        self.ops += 1;
        self.whole.record(span(timing.issued_ns, timing.applied_ns));
        self.queue
            .record(span(timing.issued_ns, timing.published_ns));
        self.transport
            .record(span(timing.published_ns, timing.received_ns));
        self.apply
            .record(span(timing.received_ns, timing.applied_ns));
        self.tick_delay
            .record_value(timing.applied_tick.saturating_sub(timing.issued_tick));
    }

    /// Adds another pod's ops.
    pub fn merge(&mut self, other: &OpStages) {
        self.ops += other.ops;
        self.whole.merge(&other.whole);
        self.queue.merge(&other.queue);
        self.transport.merge(&other.transport);
        self.apply.merge(&other.apply);
        self.tick_delay.merge(&other.tick_delay);
    }

    /// Percentiles of every stage.
    pub fn summary(&self) -> OpStagesSummary {
        let ticks = self.tick_delay.summary();
        OpStagesSummary {
            ops: self.ops,
            whole: self.whole.summary(),
            queue: self.queue.summary(),
            transport: self.transport.summary(),
            apply: self.apply.summary(),
            ticks: TickDelaySummary {
                p50: ticks.p50_ns,
                p99: ticks.p99_ns,
                p999: ticks.p999_ns,
                max: ticks.max_ns,
            },
        }
    }
}
