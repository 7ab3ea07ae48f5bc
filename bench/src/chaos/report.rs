//! What `seam chaos` prints.

use seam_proxy::ClusterStats;
use serde::Serialize;

use super::Fault;
use super::inject::InjectCounts;
use crate::ledger::{Followed, NameCounts};
use crate::node::{NodeProgress, NodeReport, TransportCounts};
use crate::run::ownership::{self, Ownership};
use crate::scene::Scene;

/// Faults injected and survived, by kind.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct FaultCounts {
    /// Pods killed with SIGKILL and restarted with `--rejoin`.
    pub kill: u64,
    /// Of those, after which every pod ran again within 5 s.
    pub kill_survived: u64,
    /// Pods stopped with SIGSTOP for a second.
    pub stop: u64,
    /// Survived.
    pub stop_survived: u64,
    /// Redis server kills and restarts.
    pub redis_restart: u64,
    /// Survived.
    pub redis_restart_survived: u64,
}

impl FaultCounts {
    pub(super) fn survived(&mut self, fault: Fault) {
        match fault {
            Fault::Kill => self.kill_survived += 1,
            Fault::Stop => self.stop_survived += 1,
            Fault::RestartRedis => self.redis_restart_survived += 1,
        }
    }

    fn all_survived(&self) -> bool {
        self.kill == self.kill_survived
            && self.stop == self.stop_survived
            && self.redis_restart == self.redis_restart_survived
    }

    /// The fault kinds a run planned (Redis restarts only over Redis) and never injected: a run
    /// without faults proves nothing.
    fn missing(&self, redis: bool) -> Vec<String> {
        let mut missing = Vec::new();
        for (name, count, planned) in [
            ("kill", self.kill, true),
            ("stop", self.stop, true),
            ("Redis restart", self.redis_restart, redis),
        ] {
            if planned && count == 0 {
                missing.push(format!(
                    "no {name} was injected (run longer or fault more often)"
                ));
            }
        }
        missing
    }
}

/// Largest growth of a pod's memory after warm-up that passes, percent: the end of the run
/// against the end of warm-up, and the highest sample after warm-up against the highest of
/// warm-up. Memory given back (a negative figure) passes whatever its size.
pub const MEMORY_BOUND_PCT: f64 = 10.0;

/// One progress line's memory figure.
#[derive(Debug, Clone, Copy)]
pub struct MemorySample {
    /// Seconds since the run was launched.
    pub at_s: f64,
    /// Resident set, KiB.
    pub rss_kib: u64,
    /// Entities the pod owned (its load: adopted bodies count).
    pub owned: usize,
}

/// One pod's memory after warm-up.
#[derive(Debug, Clone, Serialize)]
pub struct MemoryRow {
    /// Scene cluster.
    pub pod: String,
    /// Seconds of the (last) incarnation's life taken as warm-up: the first half of it, at
    /// least 10 s; and when the pod first holds its largest custody later than that (a dead or
    /// stopped neighbour's bodies adopted beside its own, see `largest_custody_end`), until
    /// that custody ends. A pod's
    /// memory steps up the first time it holds that many bodies (Rapier's arenas, and
    /// shared-memory pages its neighbours' bursts touch for the first time) and then stays; a
    /// leak grows on with no more bodies. So what follows is judged against what came before.
    pub warmup_s: f64,
    /// RSS at the end of warm-up, KiB.
    pub base_kib: u64,
    /// Largest RSS during warm-up, KiB: the high-water mark of a pod that has been through
    /// the faults once (adopting a stopped neighbour's entities holds more bodies for a while).
    pub warmup_max_kib: u64,
    /// Largest RSS after warm-up, KiB.
    pub max_kib: u64,
    /// RSS at the last sample, KiB.
    pub end_kib: u64,
    /// Growth of the last sample over the base, percent (`None`: the incarnation lived too
    /// short to judge).
    pub growth_pct: Option<f64>,
    /// Growth of the largest sample after warm-up over the end of warm-up (the base),
    /// percent: memory is flat when the peak, not only the end, stays near the base.
    pub peak_growth_pct: Option<f64>,
    /// One sample every 30 s of the incarnation's life: (seconds since launch, KiB).
    pub series_kib: Vec<(f64, u64)>,
}

impl MemoryRow {
    /// From the memory samples of a pod's last incarnation (see [`Self::warmup_s`]); a measure
    /// needs 10 s after warm-up.
    pub fn new(pod: &str, samples: &[MemorySample]) -> Self {
        let first = samples.first().map_or(0.0, |s| s.at_s);
        let lived = samples.last().map_or(0.0, |s| s.at_s) - first;
        let warmup_s = (lived / 2.0)
            .max(10.0)
            .max(largest_custody_end(samples) - first);
        let (during, after): (Vec<&MemorySample>, Vec<&MemorySample>) =
            samples.iter().partition(|s| s.at_s - first < warmup_s);
        let after: Vec<u64> = after.iter().map(|s| s.rss_kib).collect();
        let warmup_max_kib = during.iter().map(|s| s.rss_kib).max().unwrap_or(0);
        let base_kib = after.first().copied().unwrap_or(0);
        let max_kib = after.iter().copied().max().unwrap_or(0);
        let end_kib = after.last().copied().unwrap_or(0);
        let judged = lived >= warmup_s + 10.0 && base_kib > 0 && warmup_max_kib > 0;
        let growth = |kib: u64, base: u64| (kib as f64 - base as f64) / base as f64 * 100.0;
        let mut series_kib = Vec::new();
        for s in samples {
            if series_kib
                .last()
                .is_none_or(|&(last, _): &(f64, u64)| s.at_s - last >= 30.0)
            {
                series_kib.push((s.at_s, s.rss_kib));
            }
        }
        Self {
            pod: pod.to_owned(),
            warmup_s,
            base_kib,
            warmup_max_kib,
            max_kib,
            end_kib,
            growth_pct: judged.then(|| growth(end_kib, base_kib)),
            peak_growth_pct: judged.then(|| growth(max_kib, base_kib)),
            series_kib,
        }
    }

    /// Whether the pod's memory stayed within [`MEMORY_BOUND_PCT`] (`None`: not judged).
    pub fn holds(&self) -> Option<bool> {
        let (end, peak) = (self.growth_pct?, self.peak_growth_pct?);
        Some(end <= MEMORY_BOUND_PCT && peak <= MEMORY_BOUND_PCT)
    }
}

/// A pod holds a neighbour's bodies in custody when it owns more than this many times its
/// usual load (the median of its samples).
const CUSTODY_OVER_USUAL: f64 = 1.25;

/// A custody counts as the pod's largest from this share of the most it ever owned.
const LARGEST_LOAD_SHARE: f64 = 0.9;

/// When a pod's first hold of its largest custody ended (seconds since launch): the first
/// sample, after the pod first owned at least [`LARGEST_LOAD_SHARE`] of the most it ever owned,
/// at which it owned less again (the last sample if it never did); 0 when the pod never held
/// more than [`CUSTODY_OVER_USUAL`] times its usual load.
fn largest_custody_end(samples: &[MemorySample]) -> f64 {
    let mut loads: Vec<usize> = samples.iter().map(|s| s.owned).collect();
    loads.sort_unstable();
    let (Some(&usual), Some(&most)) = (loads.get(loads.len() / 2), loads.last()) else {
        return 0.0;
    };
    if (most as f64) <= usual as f64 * CUSTODY_OVER_USUAL {
        return 0.0;
    }
    let largest = |s: &MemorySample| s.owned as f64 >= most as f64 * LARGEST_LOAD_SHARE;
    let reached = samples.iter().position(largest).unwrap_or(0);
    samples[reached..]
        .iter()
        .find(|s| !largest(s))
        .or(samples.last())
        .map_or(0.0, |s| s.at_s)
}

/// Frames the pods took and refused, by reason.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct FrameCounts {
    /// Taken.
    pub accepted: u64,
    /// Did not decode.
    pub malformed: u64,
    /// Another format version.
    pub wrong_version: u64,
    /// Not from the cluster their channel names, or not from a neighbour.
    pub wrong_sender: u64,
    /// Replays: a tick of the sender already taken.
    pub replayed: u64,
    /// Tagged further ahead than the sender could be.
    pub implausible: u64,
    /// Lost to a full receive buffer.
    pub overflow: u64,
    /// Dropped by a pod with a frame key: no tag.
    pub untagged: u64,
    /// Dropped by a pod with a frame key: a wrong tag.
    pub bad_tag: u64,
    /// States ignored (claims on another cluster's entity, NaN, absurd values).
    pub states_rejected: u64,
}

/// Routed ops (or contact reports), by what became of them (see `seam_proxy::ClusterStats`).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct OpCounts {
    /// Made by game code (or the settling of seam contacts) and sent to an owner, each once
    /// however often it was sent.
    pub routed: u64,
    /// Applied by an owner.
    pub applied: u64,
    /// Dropped as too old: by a receiver (older than `max_op_age_ticks`) or by their sender
    /// (unanswered that long).
    pub dropped_stale: u64,
    /// Dropped: their entity existed nowhere the sender or the receiver knew of.
    pub dropped_gone: u64,
    /// Dropped: invalid values, or values beyond the bound.
    pub dropped_invalid: u64,
    /// Dropped: out of the settled window, or the sender's queue for the owner full.
    pub dropped_overflow: u64,
    /// Sends after the first.
    pub resent: u64,
    /// Received again after being settled: answered, not applied again.
    pub repeated: u64,
    /// Forwarded after a hand-off.
    pub forwarded: u64,
    /// Unanswered when their sender stopped at the end of the run (sent in its last ticks).
    pub unanswered_at_end: u64,
    /// Unanswered when their sender was killed (at its last progress line): they went with
    /// it, applied or not.
    pub unanswered_killed: u64,
}

impl OpCounts {
    /// Everything an op can end as, summed: applied or dropped by a reason.
    pub fn settled(&self) -> u64 {
        self.applied
            + self.dropped_stale
            + self.dropped_gone
            + self.dropped_invalid
            + self.dropped_overflow
    }

    /// Routed and neither applied, nor dropped by a reason, nor still unanswered when its
    /// sender stopped or was killed: lost. (An op applied by an owner that was killed before
    /// its answer went out, then let expire by its sender, counts twice and can hide one.)
    pub fn lost(&self) -> u64 {
        self.routed
            .saturating_sub(self.settled() + self.unanswered_at_end + self.unanswered_killed)
    }

    /// Outcomes beyond the ops routed: an op applied twice, or counted at its owner and also
    /// unanswered at a sender that stopped or was killed, or applied and also let expire by a
    /// sender whose answer was lost with a killed owner.
    pub fn surplus(&self) -> u64 {
        self.settled().saturating_sub(self.routed)
    }
}

/// Deaths, adoptions and outages.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct RecoveryCounts {
    /// Neighbours taken for dead.
    pub neighbours_lost: u64,
    /// Heard again.
    pub neighbours_rejoined: u64,
    /// Entities adopted from a dead neighbour.
    pub entities_adopted: u64,
    /// Handed back to a neighbour that returned claiming them.
    pub entities_returned: u64,
    /// Hand-offs a dead neighbour never took, taken back.
    pub handoffs_reclaimed: u64,
    /// Connections to the server lost.
    pub disconnects: u64,
    /// Re-established.
    pub reconnects: u64,
    /// Time without the server, summed over pods, s.
    pub down_s: f64,
    /// Publishes dropped meanwhile.
    pub dropped_while_down: u64,
}

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
    /// the receiver's own copy), `dropped_stale` those a receiver found too old,
    /// `dropped_gone` those their sender gave up on or forgot because the pair became its own.
    pub contacts: OpCounts,
    /// Deaths, adoptions, outages.
    pub recovery: RecoveryCounts,
    /// Every entity owned once at the end?
    pub ownership: Ownership,
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
    /// Redis restarts were planned.
    pub redis: bool,
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
            injected.forged_deliveries as i64 - frames.replayed as i64,
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
            routed: s.ops_routed,
            applied: s.ops_applied,
            dropped_stale: s.ops_dropped_stale + s.ops_expired,
            dropped_gone: s.ops_dropped_gone,
            dropped_invalid: s.ops_dropped_invalid + s.ops_dropped_absurd,
            dropped_overflow: s.ops_dropped_window + s.ops_dropped_queue_full,
            resent: s.ops_resent,
            repeated: s.ops_repeated,
            forwarded: s.ops_forwarded,
            unanswered_at_end: inputs.reports.iter().map(|r| r.ops_unanswered).sum(),
            unanswered_killed: inputs
                .dead_incarnations
                .iter()
                .map(|p| p.ops_unanswered)
                .sum(),
        };
        let contacts = OpCounts {
            routed: s.contacts_sent,
            applied: s
                .contacts_received
                .saturating_sub(s.contacts_repeated + s.contacts_dropped_stale),
            dropped_stale: s.contacts_dropped_stale,
            dropped_gone: s.contacts_given_up + s.contacts_own_now,
            resent: s.contacts_resent,
            repeated: s.contacts_repeated,
            unanswered_at_end: inputs.reports.iter().map(|r| r.contacts_unanswered).sum(),
            unanswered_killed: inputs
                .dead_incarnations
                .iter()
                .map(|p| p.contacts_unanswered)
                .sum(),
            ..OpCounts::default()
        };
        recovery.neighbours_lost = s.neighbours_lost;
        recovery.neighbours_rejoined = s.neighbours_rejoined;
        recovery.entities_adopted = s.entities_adopted;
        recovery.entities_returned = s.entities_returned;
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
            faults_missing: inputs.faults.missing(inputs.redis),
            keyed: inputs.keyed,
            injected: inputs.injected,
            frames,
            ops,
            contacts,
            recovery,
            ownership: ownership::check(scene, run_id, inputs.reports),
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
    /// refused, each forged one seen as a replay. With one: every delivery of either kind
    /// dropped as untagged before decoding, and none reaching the decoders.
    pub fn accounted(&self) -> bool {
        let i = &self.injected;
        if self.keyed {
            self.frames.untagged == i.garbage_deliveries + i.forged_deliveries
                && self.garbage_refused() == 0
                && self.frames.replayed == 0
                && self.frames.bad_tag == 0
        } else {
            self.garbage_refused() == i.garbage_deliveries
                && self.frames.replayed == i.forged_deliveries
        }
    }

    /// Whether every entity adopted from a dead or stopped pod, and every hand-off to it taken
    /// back, was handed back to it.
    pub fn adoptions_returned(&self) -> bool {
        let r = &self.recovery;
        r.entities_adopted + r.handoffs_reclaimed == r.entities_returned
    }

    /// Whether the pods' ledgers name every op and contact report their counters count (a
    /// pod writes its ledger before the progress line that counts what it wrote, so even a
    /// killed pod's ledger covers its last counters): without this, ledgers never written
    /// would follow nothing and find nothing wrong.
    pub fn ledgers_complete(&self) -> bool {
        self.by_name.ops.sent >= self.ops.routed
            && self.by_name.contacts.sent >= self.contacts.routed
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

/// The report as text.
pub fn table(r: &ChaosReport) -> String {
    let mut out = format!(
        "seam chaos: {} ({} pods) on {}, {:.0} s at {} Hz ({:.1} s wall)\n\n",
        r.scene, r.pods, r.transport, r.duration_s, r.rate_hz, r.wall_s
    );
    let f = &r.faults;
    out += &format!("{:<34} {:>9} {:>9}\n", "fault", "injected", "survived");
    for (name, n, ok) in [
        ("kill (SIGKILL) + restart --rejoin", f.kill, f.kill_survived),
        ("stop (SIGSTOP 1 s) + continue", f.stop, f.stop_survived),
        (
            "Redis server kill + restart",
            f.redis_restart,
            f.redis_restart_survived,
        ),
    ] {
        out += &format!("{name:<34} {n:>9} {ok:>9}\n");
    }
    let i = &r.injected;
    let mark = |ok: bool| if ok { "" } else { "  <-- MISMATCH" };
    if r.keyed {
        out += &format!(
            "frames from a process without the key: {} garbage and {} forged published, {} \
             delivered, {} dropped untagged before decoding (decoders saw {}){}\n\n",
            i.garbage_frames,
            i.forged_frames,
            i.garbage_deliveries + i.forged_deliveries,
            r.frames.untagged,
            r.garbage_refused() + r.frames.replayed,
            mark(r.accounted())
        );
    } else {
        out += &format!(
            "{:<34} {:>9} {:>9}  delivered {}, refused {}{}\n",
            "garbage frames",
            i.garbage_frames,
            "-",
            i.garbage_deliveries,
            r.garbage_refused(),
            mark(r.garbage_refused() == i.garbage_deliveries)
        );
        out += &format!(
            "{:<34} {:>9} {:>9}  delivered {}, seen as replays {}{}\n\n",
            "forged ownership claims",
            i.forged_frames,
            "-",
            i.forged_deliveries,
            r.frames.replayed,
            mark(r.frames.replayed == i.forged_deliveries)
        );
    }
    if !r.accounted() {
        for slip in &r.accounting_slips {
            out += &format!("  unseen: {slip}\n");
        }
    }
    let o = &r.ownership;
    out += &format!(
        "entities: {} expected, {} owned once, {} lost, {} owned twice{}\n",
        o.expected,
        o.owned_once,
        o.lost.len(),
        o.duplicated.len(),
        if o.names.is_empty() {
            String::new()
        } else {
            format!(" ({})", o.names.join(", "))
        }
    );
    let fr = &r.frames;
    out += &format!(
        "frames: {} taken; refused: {} undecodable, {} other version, {} wrong sender, {} \
         replayed, {} implausible tick; {} lost to full buffers; {} states rejected\n",
        fr.accepted,
        fr.malformed,
        fr.wrong_version,
        fr.wrong_sender,
        fr.replayed,
        fr.implausible,
        fr.overflow,
        fr.states_rejected
    );
    let op = &r.ops;
    out += &format!(
        "ops: {} routed, {} applied; dropped: {} too old, {} entity gone, {} invalid, {} \
         overflow; {} unanswered at the end, {} with a killed sender; {} lost{}, {} settled \
         beyond routed; {} resent, {} repeats not applied, {} forwarded\n",
        op.routed,
        op.applied,
        op.dropped_stale,
        op.dropped_gone,
        op.dropped_invalid,
        op.dropped_overflow,
        op.unanswered_at_end,
        op.unanswered_killed,
        op.lost(),
        mark(op.lost() == 0),
        op.surplus(),
        op.resent,
        op.repeated,
        op.forwarded
    );
    let c = &r.contacts;
    out += &format!(
        "contact reports: {} sent, {} surfaced or merged; {} too old, {} given up or the pair \
         the sender's own since; \
         {} unanswered at the end, {} with a killed sender; {} lost{}, {} settled beyond sent; \
         {} resent, {} repeats not surfaced\n",
        c.routed,
        c.applied,
        c.dropped_stale,
        c.dropped_gone,
        c.unanswered_at_end,
        c.unanswered_killed,
        c.lost(),
        mark(c.lost() == 0),
        c.surplus(),
        c.resent,
        c.repeated
    );
    for (what, n, counted) in [
        ("ops", &r.by_name.ops, r.ops.routed),
        ("contact reports", &r.by_name.contacts, r.contacts.routed),
    ] {
        out += &by_name_line(what, n, counted);
    }
    if r.by_name.unreadable_lines > 0 {
        out += &format!(
            "  ({} ledger lines unreadable: cut short by a kill)\n",
            r.by_name.unreadable_lines
        );
    }
    let rc = &r.recovery;
    out += &format!(
        "recovery: {} neighbours taken for dead, {} rejoined; {} entities adopted and {} hand-offs \
         reclaimed, {} returned{}; {} disconnects, {} reconnects, {:.1} s down (pods summed), {} \
         publishes dropped while down\n",
        rc.neighbours_lost,
        rc.neighbours_rejoined,
        rc.entities_adopted,
        rc.handoffs_reclaimed,
        rc.entities_returned,
        mark(r.adoptions_returned()),
        rc.disconnects,
        rc.reconnects,
        rc.down_s,
        rc.dropped_while_down
    );
    out += &format!(
        "panics: {}; pods that ended badly: {}\n\n",
        r.panics, r.exited_badly
    );
    out += &format!(
        "{:<12} {:>9} {:>10} {:>10} {:>11} {:>10} {:>9} {:>9}\n",
        "memory", "warm-up s", "base KiB", "end KiB", "warm-up max", "peak KiB", "growth", "peak"
    );
    let percent = |g: Option<f64>| g.map_or("-".to_owned(), |g| format!("{g:+.1} %"));
    for m in &r.memory {
        out += &format!(
            "{:<12} {:>9.0} {:>10} {:>10} {:>11} {:>10} {:>9} {:>9}{}\n",
            m.pod,
            m.warmup_s,
            m.base_kib,
            m.end_kib,
            m.warmup_max_kib,
            m.max_kib,
            percent(m.growth_pct),
            percent(m.peak_growth_pct),
            mark(m.holds() != Some(false))
        );
    }
    out += &format!(
        "warm-up = first half of the pod's last life, or until its first hold of its largest \
         custody of a neighbour's bodies ended if that was later; growth = end of run over end of warm-up; \
         peak = largest sample after warm-up over the end of warm-up; each at most \
         +{MEMORY_BOUND_PCT} % (a pod whose last life was too short is not judged){}\n",
        mark(r.memory_holds())
    );
    for problem in r
        .failed_faults
        .iter()
        .chain(&r.faults_missing)
        .chain(&r.problems)
    {
        out += &format!("problem: {problem}\n");
    }
    out += if r.holds() {
        "\nresult: every target held\n"
    } else {
        "\nresult: FAILED (see above)\n"
    };
    out
}

/// What became of the names of one kind, followed across the pods' ledgers.
fn by_name_line(what: &str, n: &NameCounts, counted: u64) -> String {
    let mark = |ok: bool| if ok { "" } else { "  <-- MISMATCH" };
    let twice: Vec<String> = n
        .ended_twice
        .iter()
        .map(|(ends, count)| format!("{count} {ends}"))
        .collect();
    let mut out = format!(
        "{what} by name: {} sent{}; {} ended once ({} also applied to a stalled owner's \
         adopted copy, since dropped), {} ended twice{}, {} applied twice{}; no end: {} answered \
         (end unlogged), {} unanswered at the end, {} with a killed sender, {} lost{}; {} ended \
         unsent\n",
        n.sent,
        if n.sent >= counted {
            String::new()
        } else {
            format!(" of {counted} counted  <-- MISMATCH")
        },
        n.ended_once,
        n.applied_to_dropped_copy,
        n.ended_twice_total(),
        if twice.is_empty() {
            String::new()
        } else {
            format!(" ({})", twice.join(", "))
        },
        n.applied_twice,
        mark(n.applied_twice == 0),
        n.answered_end_unlogged,
        n.unanswered_at_end,
        n.with_killed_sender,
        n.lost,
        mark(n.lost == 0),
        n.ended_unsent
    );
    for example in &n.examples {
        out += &format!("  {example}\n");
    }
    out
}

/// The run as the two rows of RELIABILITY.md's tables (`seam chaos --markdown`): what was
/// injected and what held, then what else the pods counted.
pub fn markdown(r: &ChaosReport) -> String {
    use crate::markdown::{Align::*, Table, grouped};
    let transport = if r.transport.starts_with("redis") {
        "Redis"
    } else {
        "shm"
    };
    let redis = transport == "Redis";
    let f = &r.faults;
    let pair = |a: u64, b: u64| format!("{} / {}", grouped(a), grouped(b));
    let percent = |g: Option<f64>| g.map_or("-".to_owned(), |g| format!("{g:+.1} %"));
    let memory: Vec<String> = r
        .memory
        .iter()
        .map(|m| {
            format!(
                "{} {}, {}",
                m.pod,
                percent(m.growth_pct),
                percent(m.peak_growth_pct)
            )
        })
        .collect();
    let o = &r.ownership;
    let mut held = Table::new(&[
        ("scene", Left),
        ("transport", Left),
        ("s", Right),
        ("pods", Right),
        ("kill", Right),
        ("stop", Right),
        ("Redis restart", Right),
        ("garbage delivered / refused", Right),
        ("forged delivered / replays", Right),
        ("entities expected / once / lost / twice", Left),
        ("adopted + reclaimed / returned", Left),
        ("panics", Right),
        ("memory growth: end, peak", Left),
        ("result", Left),
    ]);
    held.row(vec![
        format!("`{}`", r.scene),
        transport.to_owned(),
        format!("{:.0}", r.duration_s),
        r.pods.to_string(),
        pair(f.kill, f.kill_survived),
        pair(f.stop, f.stop_survived),
        if redis {
            pair(f.redis_restart, f.redis_restart_survived)
        } else {
            "—".to_owned()
        },
        if r.keyed {
            pair(
                r.injected.garbage_deliveries + r.injected.forged_deliveries,
                r.frames.untagged,
            )
        } else {
            pair(r.injected.garbage_deliveries, r.garbage_refused())
        },
        if r.keyed {
            "(untagged)".to_owned()
        } else {
            pair(r.injected.forged_deliveries, r.frames.replayed)
        },
        format!(
            "{} / {} / {} / {}",
            grouped(o.expected as u64),
            grouped(o.owned_once as u64),
            o.lost.len(),
            o.duplicated.len()
        ),
        format!(
            "{} + {} / {}",
            grouped(r.recovery.entities_adopted),
            grouped(r.recovery.handoffs_reclaimed),
            grouped(r.recovery.entities_returned)
        ),
        r.panics.to_string(),
        memory.join("; "),
        if r.holds() { "held" } else { "FAILED" }.to_owned(),
    ]);
    let (fr, op, rc) = (&r.frames, &r.ops, &r.recovery);
    let mut counted = Table::new(&[
        ("scene", Left),
        ("transport", Left),
        ("frames taken", Right),
        ("lost to full buffers", Right),
        ("implausible", Right),
        ("states rejected", Right),
        ("ops routed / applied / too old / lost", Left),
        ("resent / repeats", Left),
        ("unanswered at end + at kills / settled beyond routed", Left),
        ("contact reports sent / surfaced / too old / lost", Left),
        (
            "by name, ops; reports: ended twice / applied twice / lost",
            Left,
        ),
        ("taken for dead / rejoined", Left),
        (
            "disconnects / reconnects, s down (pods summed), publishes dropped",
            Left,
        ),
    ]);
    counted.row(vec![
        format!("`{}`", r.scene),
        transport.to_owned(),
        grouped(fr.accepted),
        grouped(fr.overflow),
        grouped(fr.implausible),
        grouped(fr.states_rejected),
        format!(
            "{} / {} / {} / {}",
            grouped(op.routed),
            grouped(op.applied),
            grouped(op.dropped_stale),
            grouped(op.lost())
        ),
        pair(op.resent, op.repeated),
        format!(
            "{} + {} / {}",
            grouped(op.unanswered_at_end),
            grouped(op.unanswered_killed),
            grouped(op.surplus())
        ),
        format!(
            "{} / {} / {} / {}",
            grouped(r.contacts.routed),
            grouped(r.contacts.applied),
            grouped(r.contacts.dropped_stale),
            grouped(r.contacts.lost())
        ),
        {
            let (o, c) = (&r.by_name.ops, &r.by_name.contacts);
            format!(
                "{} / {} / {}; {} / {} / {}",
                grouped(o.ended_twice_total()),
                grouped(o.applied_twice),
                grouped(o.lost),
                grouped(c.ended_twice_total()),
                grouped(c.applied_twice),
                grouped(c.lost)
            )
        },
        pair(rc.neighbours_lost, rc.neighbours_rejoined),
        if redis {
            format!(
                "{} / {}, {:.1} s, {}",
                grouped(rc.disconnects),
                grouped(rc.reconnects),
                rc.down_s,
                grouped(rc.dropped_while_down)
            )
        } else {
            "—".to_owned()
        },
    ]);
    held.render() + "\n" + &counted.render()
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
