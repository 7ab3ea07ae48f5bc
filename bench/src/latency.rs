//! Latency samples and their summary.

use hdrhistogram::Histogram;
use serde::{Deserialize, Serialize};

/// Records latencies in nanoseconds, from 1 ns to 60 s at 3 significant digits. Serialises as
/// its non-empty buckets, `[[value, count], …]`, so recorders from several processes can be
/// merged.
#[derive(Clone, Serialize, Deserialize)]
#[serde(from = "Vec<(u64, u64)>", into = "Vec<(u64, u64)>")]
pub struct LatencyRecorder {
    histogram: Histogram<u64>,
}

impl Default for LatencyRecorder {
    fn default() -> Self {
        Self {
            histogram: Histogram::new_with_bounds(1, 60_000_000_000, 3)
                .expect("static histogram bounds are valid"),
        }
    }
}

impl LatencyRecorder {
    /// Adds one sample, clamped into the histogram's range.
    pub fn record(&mut self, nanos: u64) {
        self.histogram.saturating_record(nanos.max(1));
    }

    /// Adds one sample of any unit, 0 included (tick counts, say).
    pub fn record_value(&mut self, value: u64) {
        self.histogram.saturating_record(value);
    }

    /// Adds everything `other` recorded.
    pub fn merge(&mut self, other: &LatencyRecorder) {
        for bucket in other.histogram.iter_recorded() {
            self.histogram
                .saturating_record_n(bucket.value_iterated_to(), bucket.count_at_value());
        }
    }

    /// Whether nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.histogram.is_empty()
    }

    /// Percentiles of what was recorded.
    pub fn summary(&self) -> LatencySummary {
        let h = &self.histogram;
        LatencySummary {
            samples: h.len(),
            p50_ns: h.value_at_quantile(0.50),
            p99_ns: h.value_at_quantile(0.99),
            p999_ns: h.value_at_quantile(0.999),
            max_ns: h.max(),
        }
    }
}

/// Percentiles of a latency distribution, in nanoseconds.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct LatencySummary {
    /// Number of samples.
    pub samples: u64,
    /// Median.
    pub p50_ns: u64,
    /// 99th percentile.
    pub p99_ns: u64,
    /// 99.9th percentile.
    pub p999_ns: u64,
    /// Largest sample.
    pub max_ns: u64,
}

/// Nanoseconds as microseconds with two decimals, for tables.
pub fn micros(nanos: u64) -> String {
    format!("{:.2}", nanos as f64 / 1000.0)
}

impl From<Vec<(u64, u64)>> for LatencyRecorder {
    fn from(buckets: Vec<(u64, u64)>) -> Self {
        let mut recorder = LatencyRecorder::default();
        for (value, count) in buckets {
            recorder.histogram.saturating_record_n(value, count);
        }
        recorder
    }
}

impl From<LatencyRecorder> for Vec<(u64, u64)> {
    fn from(recorder: LatencyRecorder) -> Self {
        recorder
            .histogram
            .iter_recorded()
            .map(|b| (b.value_iterated_to(), b.count_at_value()))
            .collect()
    }
}

/// Median times, seconds, of `a` and `b` run alternately `rounds` times after `warmup` rounds
/// of each: a ratio of the two holds still on a noisy machine, where noise falls on both alike.
pub fn paired_medians(
    warmup: usize,
    rounds: usize,
    mut a: impl FnMut(),
    mut b: impl FnMut(),
) -> (f64, f64) {
    for _ in 0..warmup {
        a();
        b();
    }
    let (mut a_times, mut b_times) = (Vec::with_capacity(rounds), Vec::with_capacity(rounds));
    for _ in 0..rounds {
        let t = std::time::Instant::now();
        a();
        a_times.push(t.elapsed().as_secs_f64());
        let t = std::time::Instant::now();
        b();
        b_times.push(t.elapsed().as_secs_f64());
    }
    let median = |times: &mut Vec<f64>| {
        times.sort_by(f64::total_cmp);
        times.get(times.len() / 2).copied().unwrap_or(0.0)
    };
    (median(&mut a_times), median(&mut b_times))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recorders_survive_json_and_merge() {
        let mut a = LatencyRecorder::default();
        let mut b = LatencyRecorder::default();
        for v in 1..=1000 {
            a.record(v * 1000);
        }
        b.record_value(0);
        let json = serde_json::to_string(&a).expect("serialises");
        let mut back: LatencyRecorder = serde_json::from_str(&json).expect("deserialises");
        assert_eq!(back.summary().p50_ns, a.summary().p50_ns);
        back.merge(&b);
        assert_eq!(back.summary().samples, 1001);
        assert!(b.summary().max_ns == 0 && !b.is_empty());
    }
}
