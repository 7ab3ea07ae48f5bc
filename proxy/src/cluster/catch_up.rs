//! [`CatchUp`]: a pod that was stopped (a stall, a paused VM, SIGSTOP) long enough for its
//! neighbours to take it for dead runs its missed ticks back to back when it wakes. Until it
//! has caught up, its neighbours' frames come from ticks far ahead of its own; what they hand
//! or claim from it is held until its world reaches the tick they speak of (see
//! `Reconcile::hold_early`), so the body it still simulates is its own through the ticks it
//! steps late, and its adopter's from the tick the adopter's claim is from.

use crate::config::ClusterConfig;

/// How far ahead of this world a neighbour's hand-off or claim may be and still be held.
#[derive(Debug, Default)]
pub(crate) struct CatchUp {
    /// Host time of the last tick run, ns.
    last_ns: Option<u64>,
    /// The tick this world is catching up to after its last stall, with a neighbour timeout
    /// to spare, while it runs its ticks back to back (`None` otherwise).
    until: Option<u64>,
}

impl CatchUp {
    /// Notes the host time of the tick this world is about to run (`tick` the one it last
    /// stepped). A gap since the last tick of half a neighbour timeout or more in host time
    /// (the silence neighbours take for death is a whole one) is a stall: this world is
    /// behind by as many ticks as the gap lasted, and catching up while its ticks come back
    /// to back (less than 0.9 `dt` apart). A world that goes on at its pace without catching
    /// up (a loop that skips the ticks it missed) counts its ticks from another start.
    pub(crate) fn note(&mut self, tick: u64, now_ns: u64, config: &ClusterConfig) {
        let timeout = config.neighbour_timeout_ticks;
        let dt_ns = f64::from(config.dt) * 1e9;
        if let Some(last) = self.last_ns
            && timeout > 0
            && dt_ns > 0.0
        {
            let gap = now_ns.saturating_sub(last) as f64 / dt_ns;
            self.until = if gap >= (timeout / 2) as f64 {
                let until = tick + gap.round() as u64 + timeout;
                Some(self.until.map_or(until, |u| u.max(until)))
            } else {
                self.until.filter(|&until| gap < 0.9 && tick < until)
            };
        }
        self.last_ns = Some(now_ns);
    }

    /// The latest tick a neighbour's hand-off or claim to this world at `tick` is held until:
    /// a neighbour timeout ahead, or further while catching up. One from further ahead is
    /// from a neighbour that counts its ticks from another start, and is taken at once.
    pub(crate) fn holds_until(&self, tick: u64, config: &ClusterConfig) -> u64 {
        let ahead = tick + config.neighbour_timeout_ticks.max(1);
        self.until.map_or(ahead, |until| until.max(ahead))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use seam_sim::wire::ClusterId;

    fn config() -> ClusterConfig {
        ClusterConfig::new(ClusterId::named("run", "west"), Vec::new(), "shm")
    }

    #[test]
    fn ticks_on_time_hold_a_timeout_ahead() {
        let config = config();
        let mut catch_up = CatchUp::default();
        let dt_ns = (f64::from(config.dt) * 1e9) as u64;
        for tick in 0..100 {
            catch_up.note(tick, tick * dt_ns, &config);
        }
        assert_eq!(catch_up.holds_until(100, &config), 160);
    }

    #[test]
    fn a_stall_holds_as_far_as_it_lasted_while_catching_up() {
        let config = config();
        let mut catch_up = CatchUp::default();
        let dt_ns = (f64::from(config.dt) * 1e9) as u64;
        catch_up.note(10, 10 * dt_ns, &config);
        // Stopped for 200 ticks of host time, then ticks back to back.
        catch_up.note(11, 210 * dt_ns, &config);
        assert_eq!(catch_up.holds_until(11, &config), 11 + 200 + 60);
        catch_up.note(12, 210 * dt_ns + dt_ns / 4, &config);
        assert_eq!(catch_up.holds_until(12, &config), 271);
        // On its pace again without having caught up: it skips what it missed.
        catch_up.note(13, 211 * dt_ns + dt_ns / 4, &config);
        assert_eq!(catch_up.holds_until(13, &config), 73);
    }
}
