//! Who is alive: each neighbour's status from the frames it sends, taking the silent for dead,
//! adopting their entities (see `crate::adoption`) and giving them back when they return.

use seam_sim::wire::{ClusterId, EntityId, EntityState};

use crate::adoption;

use super::{Cluster, owner_role};

/// What a cluster knows of a neighbour's liveness.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NeighbourStatus {
    /// No frame from it yet.
    NotHeard,
    /// Heard within `neighbour_timeout_ticks`.
    Alive,
    /// Silent for longer than `neighbour_timeout_ticks`: taken for dead, its proxies were
    /// despawned and its entities may be adopted. A frame from it again makes it `Alive`.
    Dead,
    /// Said it was stopping on purpose ([`Cluster::leave`](crate::Cluster::leave)): never
    /// taken for dead, nothing adopted from it; hand-offs to it that it had not taken came
    /// back. A frame from it again makes it `Alive`.
    Left,
}

impl NeighbourStatus {
    /// Taken for dead or left: nothing of this cluster's goes to it (no hand-off, no routed
    /// write), and it adopts nothing.
    pub fn is_gone(self) -> bool {
        matches!(self, NeighbourStatus::Dead | NeighbourStatus::Left)
    }
}

/// What a cluster tracks of one neighbour.
#[derive(Debug, Clone, Copy)]
pub(super) struct Peer {
    pub(super) status: NeighbourStatus,
    /// This cluster's tick when it last heard from the neighbour.
    pub(super) heard_at: u64,
    /// The highest tick of the neighbour's replication frames taken so far.
    pub(super) newest_replication: Option<u64>,
    /// The same for its physics-events frames.
    pub(super) newest_events: Option<u64>,
    /// Host time (`Cluster::host_ns`) of the tick its last frame was taken in, ns.
    pub(super) heard_ns: u64,
}

impl Peer {
    /// A neighbour not heard from yet.
    pub(super) fn new() -> Self {
        Self {
            status: NeighbourStatus::NotHeard,
            heard_at: 0,
            newest_replication: None,
            newest_events: None,
            heard_ns: 0,
        }
    }
}

impl Cluster {
    /// Takes neighbours silent for too long for dead: adopts what the rule gives this cluster
    /// of their entities, despawns the rest of their proxies. While this cluster's own
    /// transport is down nobody can be heard, so nobody is taken for dead: the clock of every
    /// neighbour restarts when the transport comes back.
    pub(super) fn check_liveness(&mut self) {
        let timeout = self.config.neighbour_timeout_ticks;
        if timeout == 0 {
            return;
        }
        let now = self.sim.tick();
        let up = self.transport.is_connected();
        if !up || !self.transport_was_up {
            self.transport_was_up = up;
            for peer in self.liveness.values_mut() {
                peer.heard_at = now;
                peer.heard_ns = self.host_ns;
            }
            return;
        }
        // Silent for more than the timeout in ticks *and* in host time (timeout × dt): a pod
        // catching up after a stall runs its ticks back to back, faster than its neighbours
        // publish, and must not take them for dead for that.
        let timeout_ns = (timeout as f64 * f64::from(self.config.dt) * 1e9) as u64;
        let now_ns = self.host_ns;
        let mut lost = Vec::new();
        for (&neighbour, peer) in self.liveness.iter_mut() {
            if peer.status == NeighbourStatus::Alive
                && now.saturating_sub(peer.heard_at) > timeout
                && now_ns.saturating_sub(peer.heard_ns) > timeout_ns
            {
                peer.status = NeighbourStatus::Dead;
                lost.push(neighbour);
            }
        }
        for neighbour in lost {
            self.stats.neighbours_lost += 1;
            let adopted = self.stats.entities_adopted;
            self.adopt_from(neighbour);
            tracing::warn!(
                cluster = %self.config.cluster_id,
                %neighbour,
                silent_ticks = timeout,
                adopted = self.stats.entities_adopted - adopted,
                "neighbour taken for dead: its proxies despawned, its entities adopted"
            );
        }
    }

    /// The entities of `dead`, taken for dead just now: those the adoption rule gives this
    /// cluster become its own, from their last replicated state; those handed to `dead` that
    /// it never took come back; every other proxy of `dead` is despawned (its adopter's frames
    /// bring it back).
    pub(super) fn adopt_from(&mut self, dead: ClusterId) {
        let me = self.config.cluster_id;
        let last: Vec<EntityState> = self
            .last_states
            .swap_remove(&dead)
            .map(|frame| frame.states().filter_map(Result::ok).collect())
            .unwrap_or_default();
        let liveness = &self.liveness;
        let alive =
            |c: ClusterId| c == me || liveness.get(&c).is_none_or(|peer| !peer.status.is_gone());
        for state in last.iter().filter(|s| s.cluster_id == dead) {
            if adoption::adopter(&self.config.world, dead, state.position, alive) != Some(me) {
                continue;
            }
            let adopted = EntityState {
                cluster_id: me,
                ..*state
            };
            let done = match self.sim.info(state.id).map(|i| i.owner) {
                Some(owner) if owner == dead => self
                    .sim
                    .set_role(state.id, owner_role(state))
                    .and_then(|()| self.sim.apply_state(&adopted)),
                None => self.sim.spawn(&adopted, owner_role(state)),
                // Already someone else's here: not the dead cluster's to give.
                Some(_) => continue,
            };
            if done.is_ok() {
                self.adopted.insert(state.id, dead);
                self.stats.entities_adopted += 1;
            }
        }
        // What is left of `dead` here: entities this cluster handed to it that it never listed
        // (taken back: this cluster had them last), and proxies of entities another survivor
        // adopts.
        let left: Vec<EntityId> = self
            .sim
            .entities()
            .filter(|(_, info)| info.owner == dead)
            .map(|(id, _)| id)
            .collect();
        for id in left {
            // Never taken: its last frame does not list it as its own (it may list it as a
            // hand-off to this cluster, if this was a hand-back it never took).
            let never_taken = self
                .handed
                .swap_remove(&id)
                .filter(|_| !last.iter().any(|s| s.id == id && s.cluster_id == dead));
            // Taken back as it was handed over (a Fixed proxy has lost its velocity since).
            let reclaimed = never_taken.is_some_and(|handed| {
                let back = EntityState {
                    cluster_id: me,
                    epoch: handed.epoch + 1,
                    ..handed
                };
                self.sim.set_role(id, owner_role(&back)).is_ok()
                    && self.sim.apply_state(&back).is_ok()
            });
            if reclaimed {
                self.adopted.insert(id, dead);
                self.stats.handoffs_reclaimed += 1;
            } else if self.sim.despawn(id).is_ok() {
                self.stats.proxies_despawned += 1;
            }
        }
        // Hand-offs to it that it did take are its entities' business now (adopted above).
        self.handed.retain(|_, handed| handed.cluster_id != dead);
    }

    /// Notes a frame from `neighbour` tagged `tick` (a replication frame or not).
    pub(super) fn heard(&mut self, neighbour: ClusterId, tick: u64, replication: bool) {
        let now = self.sim.tick();
        if let Some(peer) = self.liveness.get_mut(&neighbour) {
            let back = peer.status.is_gone();
            if back {
                // Back, perhaps restarted with a lower tick: its ticks count afresh.
                self.stats.neighbours_rejoined += 1;
                peer.newest_replication = None;
                peer.newest_events = None;
            }
            peer.status = NeighbourStatus::Alive;
            peer.heard_at = now;
            peer.heard_ns = self.host_ns;
            let newest = if replication {
                &mut peer.newest_replication
            } else {
                &mut peer.newest_events
            };
            *newest = Some(newest.map_or(tick, |t| t.max(tick)));
            if back {
                let returned = self.stats.entities_returned;
                self.return_adopted(neighbour);
                tracing::info!(
                    cluster = %self.config.cluster_id,
                    %neighbour,
                    returned = self.stats.entities_returned - returned,
                    "neighbour back: what was adopted from it is handed back"
                );
            }
        }
    }

    /// `neighbour` said it is stopping (its last frames, taken this tick, were reconciled
    /// first): it is not waited for or taken for dead, and hand-offs to it that its frames
    /// never answered are taken back — it will not take them now.
    pub(super) fn neighbour_left(&mut self, neighbour: ClusterId) {
        let me = self.config.cluster_id;
        let Some(peer) = self.liveness.get_mut(&neighbour) else {
            return;
        };
        peer.status = NeighbourStatus::Left;
        self.stats.neighbours_left += 1;
        let unanswered: Vec<EntityState> = self
            .handed
            .values()
            .filter(|handed| handed.cluster_id == neighbour)
            .copied()
            .collect();
        for handed in unanswered {
            self.handed.swap_remove(&handed.id);
            let back = EntityState {
                cluster_id: me,
                epoch: handed.epoch + 1,
                ..handed
            };
            if self.sim.set_role(back.id, owner_role(&back)).is_ok()
                && self.sim.apply_state(&back).is_ok()
            {
                self.stats.handoffs_taken_back += 1;
            }
        }
        tracing::info!(
            cluster = %me,
            %neighbour,
            "neighbour left: not waited for, nothing adopted from it"
        );
    }

    /// Hands every entity adopted from `neighbour`, which is back, to it again at the next
    /// replication frame: a restarted pod starts empty and gets its entities back; a stalled
    /// one that still simulates them keeps its own copy (a hand-off of an entity it owns
    /// changes nothing there), and this cluster's copy stops.
    pub(super) fn return_adopted(&mut self, neighbour: ClusterId) {
        let me = self.config.cluster_id;
        let sim = &self.sim;
        let back: Vec<EntityId> = self
            .adopted
            .iter()
            .filter(|&(id, &from)| {
                from == neighbour && sim.info(*id).is_some_and(|i| i.owner == me)
            })
            .map(|(&id, _)| id)
            .collect();
        for id in back {
            self.adopted.swap_remove(&id);
            self.transfers.insert(id, neighbour);
            self.stats.entities_returned += 1;
        }
    }

    /// Whether a frame of a live `neighbour` is tagged no later than one of its frames of the
    /// same kind taken before: a sender publishes one per tick, in order, so it is a replay (or
    /// a forgery of a tick already seen).
    pub(super) fn replayed(&self, neighbour: ClusterId, tick: u64, replication: bool) -> bool {
        self.liveness.get(&neighbour).is_some_and(|peer| {
            let newest = if replication {
                peer.newest_replication
            } else {
                peer.newest_events
            };
            peer.status == NeighbourStatus::Alive && newest.is_some_and(|n| tick <= n)
        })
    }

    /// Whether a frame of `neighbour` tagged `tick` is further ahead than any live neighbour
    /// could be: pods share one schedule, so a neighbour is at most where this cluster is, or
    /// where its own last frame was plus one tick per `dt` of host time since (this cluster may
    /// be the one that stalled), plus twice the neighbour timeout of slack. Such a frame could
    /// only be forged, and would otherwise pass for the newest; it is dropped.
    pub(super) fn implausible(&self, neighbour: ClusterId, tick: u64) -> bool {
        let window = self.config.neighbour_timeout_ticks.saturating_mul(2);
        if window == 0 {
            return false;
        }
        let dt_ns = (f64::from(self.config.dt) * 1e9).max(1.0);
        let mine = self.sim.tick();
        self.liveness.get(&neighbour).is_some_and(|peer| {
            let elapsed = (self.host_ns.saturating_sub(peer.heard_ns) as f64 / dt_ns) as u64;
            peer.status == NeighbourStatus::Alive
                && peer
                    .newest_replication
                    .max(peer.newest_events)
                    .is_some_and(|newest| {
                        tick > newest
                            .saturating_add(elapsed)
                            .max(mine)
                            .saturating_add(window)
                    })
        })
    }
}
