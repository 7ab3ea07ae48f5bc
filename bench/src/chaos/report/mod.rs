//! What `seam chaos` found: [`ChaosReport`], the targets it judges, and (in `document`) how it
//! is shown.
//!
//! # Layout
//!
//! - here: [`ChaosReport`], made from every pod life's counters and ledgers, and the targets.
//! - `counts` — what is counted: faults, memory, frames, ops and reports, recovery.
//! - `document` — the report as one [`Document`](crate::document::Document), text or Markdown.

mod counts;
mod document;

use seam_proxy::ClusterStats;
use serde::Serialize;

use super::inject::InjectCounts;
use crate::ledger::Followed;
use crate::node::{NodeProgress, NodeReport, TransportCounts};
use crate::owners::OwnerCheck;
use crate::run::ownership::{self, Ownership};
use crate::scene::Scene;

pub use counts::{
    FaultCounts, FrameCounts, MEMORY_BOUND_PCT, MemoryRow, MemorySample, OpCounts, RecoveryCounts,
};
pub use document::document;

/// Everything `seam chaos` found.
#[derive(Debug, Clone, Serialize)]
pub struct ChaosReport {
    /// Scene name.
    pub scene: String,
    /// Pods.
    pub pods: usize,
    /// Transport URL.
    pub transport: String,
    /// Ticks per second.
    pub rate_hz: f64,
    /// Planned run, s.
    pub duration_s: f64,
    /// From launch to the end, s.
    pub wall_s: f64,
    /// Faults by kind.
    pub faults: FaultCounts,
    /// Faults not survived, and why.
    pub failed_faults: Vec<String>,
    /// Fault kinds the run planned and never injected.
    pub faults_missing: Vec<String>,
    /// Whether the pods had a frame key (and the injector none).
    pub keyed: bool,
    /// Bad frames injected.
    pub injected: InjectCounts,
    /// Frames, every pod incarnation summed (the killed ones by their last progress line).
    pub frames: FrameCounts,
    /// Routed ops.
    pub ops: OpCounts,
    /// Contact reports: `routed` counts those sent, `applied` those surfaced (or merged with
    /// the receiver's own copy), `dropped_stale` those a receiver found too old, `given_up`
    /// those their sender gave up on or forgot because the pair became its own.
    pub contacts: OpCounts,
    /// Deaths, adoptions, outages.
    pub recovery: RecoveryCounts,
    /// Every entity owned once at the end?
    pub ownership: Ownership,
    /// Every entity owned once at every tick (from the pods' owner lines)?
    pub owners_per_tick: OwnerCheck,
    /// Panic messages on the pods' stderr.
    pub panics: u64,
    /// Pods that did not end well.
    pub exited_badly: u64,
    /// Anything else that went wrong.
    pub problems: Vec<String>,
    /// Memory of each pod after warm-up.
    pub memory: Vec<MemoryRow>,
    /// Every fault with the tick it came at (what `--record` writes into the recording).
    pub fault_log: Vec<crate::record::Fault>,
    /// Where injected deliveries went unseen: each time the count of those no pod had counted
    /// changed between two faults (checked just before each fault, a second after the last
    /// burst), with the fault before.
    pub accounting_slips: Vec<String>,
    /// Every op and contact report followed by name across the pods' ledgers: what the sums
    /// in `ops` and `contacts` cannot tell (an op applied twice; one lost behind another
    /// counted twice).
    pub by_name: Followed,
}

/// What [`ChaosReport::new`] is made from.
pub(super) struct Inputs<'a> {
    pub transport: String,
    /// The pods had a frame key (the injector had none).
    pub keyed: bool,
    /// The fault kinds the run took in turn.
    pub planned: Vec<crate::chaos::Fault>,
    pub rate: f64,
    pub duration_s: f64,
    pub wall_s: f64,
    pub faults: FaultCounts,
    pub failed_faults: Vec<String>,
    pub injected: InjectCounts,
    pub reports: &'a [NodeReport],
    pub dead_incarnations: &'a [NodeProgress],
    pub panics: u64,
    pub exited_badly: u64,
    pub problems: Vec<String>,
    pub memory: Vec<MemoryRow>,
    pub fault_log: Vec<crate::record::Fault>,
    pub accounting_slips: Vec<String>,
    pub by_name: Followed,
    pub owners: OwnerCheck,
}

/// The counters of pod lives (one pod's several lives, several pods) summed: the cluster's,
/// the frames', and the transport's outages.
fn tally<'a>(
    lives: impl IntoIterator<Item = (&'a ClusterStats, &'a TransportCounts)>,
) -> (ClusterStats, FrameCounts, RecoveryCounts) {
    let mut s = ClusterStats::default();
    let mut frames = FrameCounts::default();
    let mut recovery = RecoveryCounts::default();
    for (stats, t) in lives {
        s += stats;
        frames.malformed += t.malformed_drops;
        frames.overflow += t.overflow_drops;
        frames.untagged += t.untagged_drops;
        frames.bad_tag += t.bad_tag_drops;
        recovery.disconnects += t.disconnects;
        recovery.reconnects += t.reconnects;
        recovery.down_s += t.down_ns as f64 / 1e9;
        recovery.dropped_while_down += t.dropped_while_down;
    }
    frames.accepted = s.frames_accepted;
    frames.malformed += s.frames_malformed;
    frames.wrong_version = s.frames_wrong_version;
    frames.wrong_sender = s.frames_wrong_sender;
    frames.replayed = s.frames_replayed;
    frames.implausible = s.frames_implausible;
    frames.stale = s.frames_stale;
    frames.states_rejected = s.states_rejected;
    (s, frames, recovery)
}

/// Injected deliveries no pod has counted yet, by the pods' latest counters: garbage not
/// refused and forged claims not seen as replays (with a key: deliveries not dropped
/// untagged). Negative if counted more often than delivered.
pub(super) fn injected_unseen<'a>(
    keyed: bool,
    injected: &InjectCounts,
    lives: impl IntoIterator<Item = (&'a ClusterStats, &'a TransportCounts)>,
) -> (i64, i64) {
    let (_, frames, _) = tally(lives);
    let refused = (frames.malformed + frames.wrong_version + frames.wrong_sender) as i64;
    if keyed {
        let delivered = (injected.garbage_deliveries + injected.forged_deliveries) as i64;
        (delivered - frames.untagged as i64, 0)
    } else {
        (
            injected.garbage_deliveries as i64 - refused,
            injected.forged_deliveries as i64 - (frames.replayed + frames.stale) as i64,
        )
    }
}

impl ChaosReport {
    pub(super) fn new(scene: &Scene, run_id: &str, inputs: Inputs<'_>) -> Self {
        let (s, frames, mut recovery) = tally(
            inputs
                .reports
                .iter()
                .map(|r| (&r.cluster_stats, &r.transport_stats))
                .chain(
                    inputs
                        .dead_incarnations
                        .iter()
                        .map(|p| (&p.cluster_stats, &p.transport_stats)),
                ),
        );
        let ops = OpCounts {
            resent: s.ops_resent,
            repeated: s.ops_repeated,
            forwarded: s.ops_forwarded,
            ..OpCounts::by_name(&inputs.by_name.ops, s.ops_routed)
        };
        let contacts = OpCounts {
            resent: s.contacts_resent,
            repeated: s.contacts_repeated,
            ..OpCounts::by_name(&inputs.by_name.contacts, s.contacts_sent)
        };
        recovery.neighbours_lost = s.neighbours_lost;
        recovery.neighbours_rejoined = s.neighbours_rejoined;
        recovery.entities_adopted = s.entities_adopted;
        recovery.entities_returned = s.entities_returned;
        recovery.adoptions_yielded = s.adoptions_yielded;
        recovery.handoffs_reclaimed = s.handoffs_reclaimed;
        Self {
            scene: scene.name.clone(),
            pods: scene.clusters.len(),
            transport: inputs.transport,
            rate_hz: inputs.rate,
            duration_s: inputs.duration_s,
            wall_s: inputs.wall_s,
            faults: inputs.faults,
            failed_faults: inputs.failed_faults,
            faults_missing: inputs.faults.missing(&inputs.planned),
            keyed: inputs.keyed,
            injected: inputs.injected,
            frames,
            ops,
            contacts,
            recovery,
            ownership: ownership::check(scene, run_id, inputs.reports),
            owners_per_tick: inputs.owners,
            panics: inputs.panics,
            exited_badly: inputs.exited_badly,
            problems: inputs.problems,
            memory: inputs.memory,
            fault_log: inputs.fault_log,
            accounting_slips: inputs.accounting_slips,
            by_name: inputs.by_name,
        }
    }

    /// Garbage deliveries the pods refused as undecodable, other version or wrong sender.
    pub fn garbage_refused(&self) -> u64 {
        self.frames.malformed + self.frames.wrong_version + self.frames.wrong_sender
    }

    /// Whether every injected frame is accounted for. Without a key: each garbage delivery
    /// refused, each forged one seen as a replay (or, copied from a pod restarted since, as
    /// stale). With one: every delivery of either kind
    /// dropped as untagged before decoding, and none reaching the decoders.
    pub fn accounted(&self) -> bool {
        let i = &self.injected;
        if self.keyed {
            self.frames.untagged == i.garbage_deliveries + i.forged_deliveries
                && self.garbage_refused() == 0
                && self.frames.replayed + self.frames.stale == 0
                && self.frames.bad_tag == 0
        } else {
            self.garbage_refused() == i.garbage_deliveries
                && self.frames.replayed + self.frames.stale == i.forged_deliveries
        }
    }

    /// Whether every entity adopted from a dead or stopped pod, and every hand-off to it taken
    /// back, was handed back to it, or yielded to a later claim of a third cluster.
    pub fn adoptions_returned(&self) -> bool {
        let r = &self.recovery;
        r.entities_adopted + r.handoffs_reclaimed == r.entities_returned + r.adoptions_yielded
    }

    /// Whether the pods' ledgers name every op and contact report their counters count (a
    /// pod writes its ledger before the progress line that counts what it wrote, so even a
    /// killed pod's ledger covers its last counters): without this, ledgers never written
    /// would follow nothing and find nothing wrong.
    pub fn ledgers_complete(&self) -> bool {
        self.by_name.ops.sent >= self.ops.counted_routed
            && self.by_name.contacts.sent >= self.contacts.counted_routed
    }

    /// Whether memory held: every pod judged stayed within its bound, and a run long enough
    /// for every last incarnation to be judged (a minute or more: kills stop at half-time)
    /// judged at least one.
    pub fn memory_holds(&self) -> bool {
        let judged: Vec<bool> = self.memory.iter().filter_map(MemoryRow::holds).collect();
        judged.iter().all(|&ok| ok) && (self.duration_s < 60.0 || !judged.is_empty())
    }

    /// Whether the run met every target: every planned fault kind injected and every fault
    /// survived, every injected frame accounted for, no entity lost or owned twice, every
    /// adoption returned, no routed op or contact report lost or applied twice (by the sums,
    /// and followed by name), memory within its bound, no panic, every pod ended well, nothing
    /// else went wrong.
    pub fn holds(&self) -> bool {
        self.faults.all_survived()
            && self.failed_faults.is_empty()
            && self.faults_missing.is_empty()
            && self.accounted()
            && self.ownership.holds()
            && self.owners_per_tick.holds()
            && self.adoptions_returned()
            && self.ops.lost() == 0
            && self.contacts.lost() == 0
            && self.ledgers_complete()
            && self.by_name.ops.holds()
            && self.by_name.contacts.holds()
            && self.memory_holds()
            && self.panics == 0
            && self.exited_badly == 0
            && self.problems.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One sample a second for `secs` seconds: resident set and load from the closures.
    fn life(
        secs: u32,
        rss: impl Fn(f64) -> u64,
        owned: impl Fn(f64) -> usize,
    ) -> Vec<MemorySample> {
        (0..=secs)
            .map(|t| {
                let at_s = f64::from(t);
                MemorySample {
                    at_s,
                    rss_kib: rss(at_s),
                    owned: owned(at_s),
                }
            })
            .collect()
    }

    #[test]
    fn injected_frames_are_unseen_until_some_life_counts_them() {
        let injected = InjectCounts {
            garbage_frames: 10,
            garbage_deliveries: 30,
            forged_frames: 2,
            forged_deliveries: 6,
        };
        let mut alive = ClusterStats {
            frames_malformed: 10,
            frames_wrong_version: 5,
            frames_wrong_sender: 5,
            frames_replayed: 4,
            ..ClusterStats::default()
        };
        let transport = TransportCounts {
            malformed_drops: 6,
            untagged_drops: 33,
            ..TransportCounts::default()
        };
        let killed = ClusterStats {
            frames_malformed: 3,
            frames_replayed: 2,
            ..ClusterStats::default()
        };
        let none = TransportCounts::default();
        // 6 + 10 + 5 + 5 + 3 refused of 30; 4 + 2 replays of 6.
        assert_eq!(
            injected_unseen(false, &injected, [(&alive, &transport), (&killed, &none)]),
            (1, 0)
        );
        alive.frames_malformed += 2;
        assert_eq!(
            injected_unseen(false, &injected, [(&alive, &transport), (&killed, &none)]),
            (-1, 0)
        );
        // With a key: 36 deliveries, 33 dropped untagged.
        assert_eq!(
            injected_unseen(true, &injected, [(&alive, &transport), (&killed, &none)]),
            (3, 0)
        );
    }

    #[test]
    fn a_leak_fails_and_flat_memory_holds() {
        let leak = MemoryRow::new("p", &life(40, |t| 30_000 + (t * 200.0) as u64, |_| 600));
        assert_eq!(leak.holds(), Some(false), "{leak:?}");
        let flat = MemoryRow::new("p", &life(40, |_| 30_000, |_| 600));
        assert_eq!(flat.holds(), Some(true), "{flat:?}");
    }

    #[test]
    fn a_peak_after_warm_up_is_judged_against_the_end_of_warm_up() {
        // A spike in warm-up does not excuse one after it: memory must stay flat, peak and
        // end, against where warm-up left it.
        let rss = |t: f64| match t {
            t if (5.0..8.0).contains(&t) => 34_000,
            t if (30.0..33.0).contains(&t) => 33_500,
            _ => 30_000,
        };
        let row = MemoryRow::new("p", &life(40, rss, |_| 600));
        assert_eq!(row.growth_pct, Some(0.0));
        assert!(row.peak_growth_pct.is_some_and(|p| p > 10.0), "{row:?}");
        assert_eq!(row.holds(), Some(false), "{row:?}");
    }

    #[test]
    fn the_step_of_a_first_custody_late_in_life_is_warm_up() {
        // Adopts a neighbour's 600 bodies from 16 s to 19 s of a 30 s life; memory steps up
        // by 13 % and stays.
        let custody = |t: f64| {
            if (16.0..19.0).contains(&t) {
                1_200
            } else {
                600
            }
        };
        let rss = |t: f64| if t < 16.0 { 30_000 } else { 34_000 };
        let row = MemoryRow::new("p", &life(30, rss, custody));
        assert_eq!(row.warmup_s, 19.0);
        assert_eq!(row.holds(), Some(true), "{row:?}");
        // Without the custody the same step is growth.
        let row = MemoryRow::new("p", &life(30, rss, |_| 600));
        assert_eq!(row.warmup_s, 15.0);
        assert_eq!(row.holds(), Some(false), "{row:?}");
    }

    #[test]
    fn memory_that_grows_on_after_the_custody_fails() {
        let custody = |t: f64| {
            if (14.0..17.0).contains(&t) {
                1_200
            } else {
                600
            }
        };
        let rss = |t: f64| 30_000 + (t * 200.0) as u64;
        let row = MemoryRow::new("p", &life(60, rss, custody));
        assert_eq!(row.warmup_s, 30.0);
        assert_eq!(row.holds(), Some(false), "{row:?}");
    }

    #[test]
    fn a_custody_that_never_ends_is_not_judged() {
        let custody = |t: f64| if t >= 30.0 { 1_200 } else { 600 };
        let row = MemoryRow::new("p", &life(40, |_| 30_000, custody));
        assert_eq!(row.warmup_s, 40.0);
        assert_eq!(row.holds(), None, "{row:?}");
    }
}
