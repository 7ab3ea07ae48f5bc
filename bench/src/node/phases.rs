//! Where a pod's CPU goes: the thread CPU time of each phase of its ticks
//! (`seam_proxy::PhaseCpu`), and Rapier's narrow phase sampled now and then
//! (`seam_sim::PairCensus`): how much of the step is pairs with proxies.

use seam_proxy::{Phase, PhaseCpu};
use seam_sim::PairCensus;
use serde::{Deserialize, Serialize};

use crate::latency::LatencyRecorder;

/// Ticks between two samples of the narrow phase (a pass over every pair each).
pub const CENSUS_EVERY: u64 = 30;

/// One phase's thread CPU time over the run.
#[derive(Clone, Default, Serialize, Deserialize)]
pub struct PhaseTime {
    /// The phase (`seam_proxy::Phase::name`).
    pub phase: String,
    /// Per tick, ns.
    pub per_tick: LatencyRecorder,
    /// Summed over the ticks, ns.
    pub total_ns: u64,
}

/// A pod's phases and narrow-phase samples.
#[derive(Clone, Default, Serialize, Deserialize)]
pub struct PhaseTally {
    /// Ticks measured.
    pub ticks: u64,
    /// Every phase, in the order a tick runs them.
    pub phases: Vec<PhaseTime>,
    /// Samples of the narrow phase taken.
    pub census_samples: u64,
    /// Their counts, summed.
    pub census: PairCensus,
}

impl PhaseTally {
    /// Adds one tick's phases.
    pub fn record(&mut self, cpu: &PhaseCpu) {
        if self.phases.is_empty() {
            self.phases = (Phase::ALL.iter())
                .map(|p| PhaseTime {
                    phase: p.name().to_owned(),
                    ..PhaseTime::default()
                })
                .collect();
        }
        for (time, (_, ns)) in self.phases.iter_mut().zip(cpu.iter()) {
            time.per_tick.record(ns);
            time.total_ns += ns;
        }
        self.ticks += 1;
    }

    /// Adds a sample of the narrow phase.
    pub fn sample(&mut self, census: &PairCensus) {
        self.census_samples += 1;
        self.census.add(census);
    }

    /// Each phase's mean thread CPU time per tick, ns, in order.
    pub fn means(&self) -> Vec<(String, f64)> {
        let ticks = self.ticks.max(1) as f64;
        (self.phases.iter())
            .map(|t| (t.phase.clone(), t.total_ns as f64 / ticks))
            .collect()
    }

    /// The narrow phase's counts averaged over the samples.
    pub fn census_mean(&self) -> CensusMean {
        let n = self.census_samples.max(1) as f64;
        let c = &self.census;
        CensusMean {
            samples: self.census_samples,
            pairs: c.pairs as f64 / n,
            pairs_with_proxy: c.pairs_with_proxy as f64 / n,
            pairs_between_proxies: c.pairs_between_proxies as f64 / n,
            touching: c.touching as f64 / n,
            touching_with_proxy: c.touching_with_proxy as f64 / n,
            touching_between_proxies: c.touching_between_proxies as f64 / n,
            contacts: c.contacts as f64 / n,
            contacts_with_proxy: c.contacts_with_proxy as f64 / n,
        }
    }
}

/// [`PairCensus`] averaged over a run's samples.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct CensusMean {
    /// Samples averaged.
    pub samples: u64,
    /// Pairs in the narrow phase.
    pub pairs: f64,
    /// With a proxy on at least one side.
    pub pairs_with_proxy: f64,
    /// With proxies on both sides.
    pub pairs_between_proxies: f64,
    /// Touching.
    pub touching: f64,
    /// Touching, with a proxy.
    pub touching_with_proxy: f64,
    /// Touching, proxies on both sides.
    pub touching_between_proxies: f64,
    /// Active contact points.
    pub contacts: f64,
    /// In pairs with a proxy.
    pub contacts_with_proxy: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phases_add_up_in_order_and_census_averages() {
        let mut tally = PhaseTally::default();
        tally.record(&PhaseCpu::default());
        assert_eq!(tally.phases.len(), Phase::ALL.len());
        assert_eq!(tally.phases[6].phase, "step");
        let census = PairCensus {
            pairs: 10,
            pairs_with_proxy: 4,
            ..PairCensus::default()
        };
        tally.sample(&census);
        tally.sample(&PairCensus::default());
        let mean = tally.census_mean();
        assert_eq!(
            (mean.samples, mean.pairs, mean.pairs_with_proxy),
            (2, 5.0, 2.0)
        );
    }
}
