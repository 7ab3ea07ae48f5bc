//! What `seam chaos` counts: faults, memory, frames, ops and reports, recovery.

use serde::Serialize;

use crate::chaos::Fault;
use crate::ledger::NameCounts;
use seam_proxy::LedgerEvent;

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
    /// Redis Cluster primaries killed (and started again a few seconds later).
    pub primary_kill: u64,
    /// Survived.
    pub primary_kill_survived: u64,
    /// Slots of live channels moved to another Redis Cluster primary.
    pub slot_move: u64,
    /// Survived.
    pub slot_move_survived: u64,
}

impl FaultCounts {
    pub(crate) fn survived(&mut self, fault: Fault) {
        match fault {
            Fault::Kill => self.kill_survived += 1,
            Fault::Stop => self.stop_survived += 1,
            Fault::RestartRedis => self.redis_restart_survived += 1,
            Fault::KillPrimary => self.primary_kill_survived += 1,
            Fault::MoveSlot => self.slot_move_survived += 1,
        }
    }

    pub(super) fn all_survived(&self) -> bool {
        self.kill == self.kill_survived
            && self.stop == self.stop_survived
            && self.redis_restart == self.redis_restart_survived
            && self.primary_kill == self.primary_kill_survived
            && self.slot_move == self.slot_move_survived
    }

    /// Counts `fault` injected.
    pub(crate) fn injected(&mut self, fault: Fault) {
        *match fault {
            Fault::Kill => &mut self.kill,
            Fault::Stop => &mut self.stop,
            Fault::RestartRedis => &mut self.redis_restart,
            Fault::KillPrimary => &mut self.primary_kill,
            Fault::MoveSlot => &mut self.slot_move,
        } += 1;
    }

    /// The fault kinds a run planned (`planned`) and never injected: a run without faults
    /// proves nothing.
    pub(super) fn missing(&self, planned: &[Fault]) -> Vec<String> {
        let mut missing = Vec::new();
        for (name, count, kind) in [
            ("kill", self.kill, Fault::Kill),
            ("stop", self.stop, Fault::Stop),
            ("Redis restart", self.redis_restart, Fault::RestartRedis),
            ("primary kill", self.primary_kill, Fault::KillPrimary),
            ("slot move", self.slot_move, Fault::MoveSlot),
        ] {
            if planned.contains(&kind) && count == 0 {
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
    /// From a pod of the sender older than one heard since (its incarnation): a forged claim
    /// copied from a frame of a pod killed and restarted since.
    pub stale: u64,
    /// Lost to a full receive buffer.
    pub overflow: u64,
    /// Dropped by a pod with a frame key: no tag.
    pub untagged: u64,
    /// Dropped by a pod with a frame key: a wrong tag.
    pub bad_tag: u64,
    /// States ignored (claims on another cluster's entity, NaN, absurd values).
    pub states_rejected: u64,
}

/// Routed ops (or contact reports), by what became of them: each followed by name across
/// every pod life's ledger ([`crate::ledger::follow`]), so a killed life's last ticks count
/// too and the counts add up — every name routed is in exactly one of `applied` to
/// `unanswered_killed`, or lost. Resends, repeats and forwards are the pods' counters (see
/// `seam_proxy::ClusterStats`).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct OpCounts {
    /// Made by game code (or the settling of seam contacts) and sent to an owner, each once
    /// however often it was sent or forwarded.
    pub routed: u64,
    /// Routed as the pods' counters sum them (a killed life's up to its last progress line):
    /// the ledgers must name at least these.
    pub counted_routed: u64,
    /// Applied by an owner (a report: surfaced, or merged with the receiver's own copy).
    pub applied: u64,
    /// Dropped by a receiver as older than `max_op_age_ticks`.
    pub dropped_stale: u64,
    /// Dropped: their entity existed nowhere the sender or the receiver knew of.
    pub dropped_gone: u64,
    /// Dropped: invalid values, or values beyond the bound.
    pub dropped_invalid: u64,
    /// Dropped: out of the settled window, or the sender's queue for the owner full.
    pub dropped_overflow: u64,
    /// Given up by their sender: unanswered past answering; a report also with nobody left
    /// to tell, or the pair its sender's own since.
    pub given_up: u64,
    /// Ended twice: applied twice, or applied and also dropped or given up.
    pub ended_twice: u64,
    /// Answered done to every sender, but no end logged (a receiver killed between
    /// answering and writing its ledger).
    pub end_unlogged: u64,
    /// Unanswered when their sender stopped at the end of the run (sent in its last ticks).
    pub unanswered_at_end: u64,
    /// Unanswered when their sender was killed: they went with it, applied or not.
    pub unanswered_killed: u64,
    /// Sends after the first.
    pub resent: u64,
    /// Received again after being settled: answered, not applied again.
    pub repeated: u64,
    /// Forwarded after a hand-off.
    pub forwarded: u64,
}

impl OpCounts {
    /// The counts of `names` followed by name; resends, repeats, forwards and what the
    /// counters routed from the pods' counters.
    pub fn by_name(names: &NameCounts, counted_routed: u64) -> Self {
        use LedgerEvent::*;
        Self {
            routed: names.sent,
            counted_routed,
            applied: names.ended_as(Applied),
            dropped_stale: names.ended_as(Stale),
            dropped_gone: names.ended_as(Gone),
            dropped_invalid: names.ended_as(Invalid),
            dropped_overflow: names.ended_as(Overflow),
            given_up: names.ended_as(GivenUp),
            ended_twice: names.ended_twice_all(),
            end_unlogged: names.answered_end_unlogged,
            unanswered_at_end: names.unanswered_at_end,
            unanswered_killed: names.with_killed_sender,
            ..Self::default()
        }
    }

    /// Everything an op can end as once, summed: applied, dropped by a reason, or given up.
    pub fn ended(&self) -> u64 {
        self.applied
            + self.dropped_stale
            + self.dropped_gone
            + self.dropped_invalid
            + self.dropped_overflow
            + self.given_up
    }

    /// Routed and neither ended (once or twice), nor answered with its end unlogged, nor
    /// still unanswered when its sender stopped or was killed: lost.
    pub fn lost(&self) -> u64 {
        self.routed.saturating_sub(
            self.ended()
                + self.ended_twice
                + self.end_unlogged
                + self.unanswered_at_end
                + self.unanswered_killed,
        )
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
    /// Adopted (or taken back) and then claimed at a later epoch by a third cluster, which
    /// had taken the entity from the dead or stalled one first: nothing to return.
    pub adoptions_yielded: u64,
    /// Connections to the server lost.
    pub disconnects: u64,
    /// Re-established.
    pub reconnects: u64,
    /// Time without the server, summed over pods, s.
    pub down_s: f64,
    /// Publishes dropped meanwhile.
    pub dropped_while_down: u64,
}
