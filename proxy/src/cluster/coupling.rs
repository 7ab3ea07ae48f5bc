//! Coupling: before each step, the proxies a body of this cluster may touch become dynamic
//! bodies of their entity's mass for the step (see `seam_sim::coupling`), with the impulses
//! game code routed to them shown.

use super::Cluster;
use crate::events::ClusterEvent;

impl Cluster {
    /// Whether proxies are coupled to this world's bodies each step ([`Cluster::couple`]):
    /// not with coupling off or custom proxies, nor without neighbours (no proxies at all).
    fn couples(&self) -> bool {
        self.config.coupling
            && self.config.proxy_mode != crate::ProxyMode::Custom
            && !self.config.neighbours.is_empty()
    }

    /// Proxies a body of this cluster may touch made dynamic bodies of their entity's mass for
    /// the step (see `seam_sim::coupling`), with the impulses routed to them shown.
    pub(super) fn couple(&mut self) {
        if !self.couples() {
            return;
        }
        let coupled = self
            .sim
            .couple_proxies(self.config.proxy_mode.role())
            .coupled;
        let count = u64::from(coupled);
        self.events.emit(ClusterEvent::ProxiesCoupled { count });
        let (tick, interval) = (self.sim.tick(), self.config.replication_interval.max(1));
        let count = self.predictions.show(&mut self.sim, tick, interval);
        self.events.emit(ClusterEvent::ImpulsesPredicted { count });
    }
}
