//! What a cluster logs of what it counts, so that nothing is lost without a word: each
//! refused frame and each dropped op is counted, and logged as a warning at the 1st, 10th,
//! 100th … of its kind (a flood of garbage or an outage logs a handful of lines, not one per
//! frame), naming the cluster and, where known, the sender.

use super::Cluster;
use crate::events::{ClusterEvent, FrameRefusal};

/// Whether a count that went from `before` to `now` reached a power of ten (1, 10, 100 …).
fn reached_a_power_of_ten(before: u64, now: u64) -> bool {
    let mut power = 1u64;
    while power <= now {
        if power > before {
            return true;
        }
        match power.checked_mul(10) {
            Some(next) => power = next,
            None => break,
        }
    }
    false
}

impl Cluster {
    /// Counts a refused frame, and logs it at the 1st, 10th, 100th … refusal for its reason,
    /// naming the sender where the frame names one (a pod still running under a cluster's id
    /// elsewhere, a neighbour from another run, one whose clock runs ahead).
    pub(super) fn refused(
        &mut self,
        reason: FrameRefusal,
        from: Option<seam_sim::wire::ClusterId>,
    ) {
        self.events
            .emit(ClusterEvent::FrameRefused { reason, from });
        let count = self.stats().frames_refused_for(reason);
        if reached_a_power_of_ten(count.saturating_sub(1), count) {
            let sender = from.map_or_else(|| "unreadable".to_owned(), |id| self.config.label(id));
            tracing::warn!(
                cluster = %self.config.label(self.config.cluster_id),
                sender,
                ?reason,
                refused_so_far = count,
                "frame refused"
            );
        }
    }

    /// Logs the routed ops dropped since the last tick once their count reaches the next
    /// power of ten, with the count of each reason so far (see `ClusterStats`).
    pub(super) fn warn_dropped_ops(&mut self) {
        let s = self.stats();
        let dropped = s.ops_dropped_invalid
            + s.ops_dropped_absurd
            + s.ops_dropped_stale
            + s.ops_expired
            + s.ops_dropped_gone
            + s.ops_dropped_window
            + s.ops_dropped_queue_full;
        let before = std::mem::replace(&mut self.ops_dropped_logged, dropped);
        if !reached_a_power_of_ten(before, dropped) {
            return;
        }
        tracing::warn!(
            cluster = %self.config.label(self.config.cluster_id),
            dropped_so_far = dropped,
            invalid = s.ops_dropped_invalid,
            beyond_max_magnitude = s.ops_dropped_absurd,
            too_old = s.ops_dropped_stale,
            unanswered_too_long = s.ops_expired,
            entity_gone = s.ops_dropped_gone,
            number_out_of_window = s.ops_dropped_window,
            too_many_unanswered = s.ops_dropped_queue_full,
            "routed ops dropped"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::reached_a_power_of_ten;

    #[test]
    fn warnings_come_at_each_power_of_ten() {
        assert!(reached_a_power_of_ten(0, 1));
        assert!(!reached_a_power_of_ten(1, 9));
        assert!(reached_a_power_of_ten(9, 10));
        assert!(reached_a_power_of_ten(5, 250));
        assert!(!reached_a_power_of_ten(100, 999));
        assert!(!reached_a_power_of_ten(7, 7));
        assert!(reached_a_power_of_ten(0, u64::MAX));
    }
}
