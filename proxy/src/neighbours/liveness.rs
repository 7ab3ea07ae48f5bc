//! [`Neighbours`]: what a cluster knows of each neighbour's liveness.

use seam_sim::wire::{ClusterId, IdMap, PhysicsEventsFrame};

use crate::authority::NeighbourView;
use crate::config::ClusterConfig;
use crate::inbox::FrameKind;

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
struct Peer {
    status: NeighbourStatus,
    /// This cluster's tick when it last heard from the neighbour.
    heard_at: u64,
    /// The highest tick of the neighbour's frames of each kind taken so far, by
    /// [`FrameKind`].
    newest: [Option<u64>; FrameKind::COUNT],
    /// Host time of the tick its last frame was taken in, ns.
    heard_ns: u64,
    /// The newest incarnation of its pod heard (see `Cluster::incarnation`).
    incarnation: Option<u64>,
}

/// What a frame's incarnation says of its sender's pod.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Incarnation {
    /// The pod heard before (or the first heard).
    Current,
    /// A pod taken over by a newer one, still publishing: its frames are refused.
    Stale,
    /// A new pod of the cluster: its ticks count afresh, and what its predecessor sent that
    /// is still held is dropped.
    Restarted,
}

impl Peer {
    /// A neighbour not heard from yet.
    fn new() -> Self {
        Self {
            status: NeighbourStatus::NotHeard,
            heard_at: 0,
            newest: [None; FrameKind::COUNT],
            heard_ns: 0,
            incarnation: None,
        }
    }

    fn newest(&self, kind: FrameKind) -> Option<u64> {
        self.newest[kind as usize]
    }
}

/// Each neighbour's liveness.
#[derive(Debug)]
pub(crate) struct Neighbours {
    peers: IdMap<ClusterId, Peer>,
    /// Whether the transport was connected at the last check.
    transport_was_up: bool,
    /// Neighbours that said they are leaving, heard last tick: taken as left this tick, so
    /// that their last replication frame, on another channel, is reconciled first.
    leaving_heard: Vec<ClusterId>,
}

impl Neighbours {
    /// The neighbours of `config`, none heard from yet.
    pub(crate) fn new(config: &ClusterConfig) -> Self {
        Self {
            peers: config
                .neighbours
                .iter()
                .map(|&n| (n, Peer::new()))
                .collect(),
            transport_was_up: true,
            leaving_heard: Vec::new(),
        }
    }

    /// What this cluster knows of `neighbour` (`None` for a non-neighbour).
    pub(crate) fn status(&self, neighbour: ClusterId) -> Option<NeighbourStatus> {
        self.peers.get(&neighbour).map(|peer| peer.status)
    }

    /// Whether `cluster` is taken for dead or has left (`false` for a non-neighbour).
    pub(crate) fn is_gone(&self, cluster: ClusterId) -> bool {
        self.status(cluster).is_some_and(NeighbourStatus::is_gone)
    }

    /// Whether `cluster` is a neighbour not taken for dead and not gone: one to send to.
    pub(crate) fn reachable(&self, cluster: ClusterId) -> bool {
        self.peers.contains_key(&cluster) && !self.is_gone(cluster)
    }

    /// Whether `neighbour` is alive and has published its events frame of `step` (or a later
    /// one): what it saw at that step has been said.
    pub(crate) fn has_reported(&self, neighbour: ClusterId, step: u64) -> bool {
        self.peers.get(&neighbour).is_some_and(|peer| {
            peer.status == NeighbourStatus::Alive
                && peer
                    .newest(FrameKind::Events)
                    .is_some_and(|newest| newest >= step)
        })
    }

    /// Whether a frame of `kind` tagged `tick` or later has been heard from `neighbour`.
    pub(crate) fn has_heard(&self, neighbour: ClusterId, kind: FrameKind, tick: u64) -> bool {
        self.peers
            .get(&neighbour)
            .and_then(|peer| peer.newest(kind))
            .is_some_and(|newest| newest >= tick)
    }

    /// Whether `neighbour` is alive and exchanging ops before the step in step with this
    /// cluster at `tick`: its last exchange frame was of this tick or one of the two before,
    /// so its frame of `tick` is worth waiting for. A neighbour that never sent one (the
    /// exchange off there, or not started), or counts its ticks from another start, is not.
    pub(crate) fn exchanges_in_step(&self, neighbour: ClusterId, tick: u64) -> bool {
        self.peers.get(&neighbour).is_some_and(|peer| {
            peer.status == NeighbourStatus::Alive
                && peer
                    .newest(FrameKind::Exchange)
                    .is_some_and(|newest| newest <= tick && newest + 2 >= tick)
        })
    }

    /// Whether every live neighbour exchanges in step with this cluster at `tick` (see
    /// [`Self::exchanges_in_step`]).
    pub(crate) fn all_alive_in_step(&self, tick: u64) -> bool {
        self.peers.iter().all(|(&n, peer)| {
            peer.status != NeighbourStatus::Alive || self.exchanges_in_step(n, tick)
        })
    }

    /// The neighbours as an authority policy sees them.
    pub(crate) fn views(&self, config: &ClusterConfig) -> Vec<NeighbourView> {
        config
            .neighbours
            .iter()
            .map(|&id| NeighbourView {
                id,
                region: config.world.iter().find(|c| c.id == id).map(|c| c.region),
                alive: !self.is_gone(id),
            })
            .collect()
    }

    /// Takes neighbours silent for too long for dead, at this cluster's tick `now` and host
    /// time `now_ns`, and returns them. While this cluster's own transport is down (`up`
    /// says whether it is connected) nobody can be heard, so nobody is taken for dead: the
    /// clock of every neighbour restarts when the transport comes back.
    pub(crate) fn find_dead(
        &mut self,
        config: &ClusterConfig,
        now: u64,
        now_ns: u64,
        up: impl FnOnce() -> bool,
    ) -> Vec<ClusterId> {
        let timeout = config.neighbour_timeout_ticks;
        if timeout == 0 {
            return Vec::new();
        }
        let up = up();
        if !up || !self.transport_was_up {
            self.transport_was_up = up;
            for peer in self.peers.values_mut() {
                peer.heard_at = now;
                peer.heard_ns = now_ns;
            }
            return Vec::new();
        }
        // Silent for more than the timeout in ticks *and* in host time (timeout × dt): a pod
        // catching up after a stall runs its ticks back to back, faster than its neighbours
        // publish, and must not take them for dead for that.
        let timeout_ns = (timeout as f64 * f64::from(config.dt) * 1e9) as u64;
        let mut lost = Vec::new();
        for (&neighbour, peer) in self.peers.iter_mut() {
            if peer.status == NeighbourStatus::Alive
                && now.saturating_sub(peer.heard_at) > timeout
                && now_ns.saturating_sub(peer.heard_ns) > timeout_ns
            {
                peer.status = NeighbourStatus::Dead;
                lost.push(neighbour);
            }
        }
        lost
    }

    /// Whether `neighbour` is alive and was heard lately: within a sixth of
    /// `neighbour_timeout_ticks` (at least two replication intervals and two ticks more) of
    /// this cluster's tick `now`, or of as long in host time `now_ns` (a pod catching up runs
    /// its ticks faster than its neighbours publish). One silent for longer is stalled, or on
    /// its way to being taken for dead: nothing is handed to it, for nobody would own what is
    /// handed until it wakes or the hand-off comes back.
    pub(crate) fn answering(
        &self,
        neighbour: ClusterId,
        now: u64,
        now_ns: u64,
        config: &ClusterConfig,
    ) -> bool {
        let within = (config.neighbour_timeout_ticks / 6).max(2 * config.replication_interval + 2);
        let within_ns = (within as f64 * f64::from(config.dt) * 1e9) as u64;
        self.peers.get(&neighbour).is_some_and(|peer| {
            peer.status == NeighbourStatus::Alive
                && (now.saturating_sub(peer.heard_at) <= within
                    || now_ns.saturating_sub(peer.heard_ns) <= within_ns)
        })
    }

    /// Notes a frame of `kind` from `neighbour` tagged `tick`, taken in at
    /// this cluster's tick `now` and host time `now_ns`. Returns whether the neighbour was
    /// gone and is back.
    pub(crate) fn heard(
        &mut self,
        neighbour: ClusterId,
        tick: u64,
        kind: FrameKind,
        now: u64,
        now_ns: u64,
    ) -> bool {
        let Some(peer) = self.peers.get_mut(&neighbour) else {
            return false;
        };
        let back = peer.status.is_gone();
        if back {
            // Back, perhaps restarted with a lower tick: its ticks count afresh.
            peer.newest = [None; FrameKind::COUNT];
        }
        peer.status = NeighbourStatus::Alive;
        peer.heard_at = now;
        peer.heard_ns = now_ns;
        let newest = &mut peer.newest[kind as usize];
        *newest = Some(newest.map_or(tick, |t| t.max(tick)));
        back
    }

    /// Notes the neighbours whose events `frames` say they are leaving: taken as left at the
    /// next tick ([`Self::take_leaving`]).
    pub(crate) fn hear_leaving(&mut self, frames: &[(PhysicsEventsFrame, u64)]) {
        self.leaving_heard.extend(
            frames
                .iter()
                .filter(|(frame, _)| frame.leaving)
                .map(|(frame, _)| frame.from),
        );
    }

    /// The neighbours heard leaving last tick, each now taken as left (those this cluster
    /// has as neighbours).
    pub(crate) fn take_leaving(&mut self) -> Vec<ClusterId> {
        let heard = std::mem::take(&mut self.leaving_heard);
        heard
            .into_iter()
            .filter(|n| match self.peers.get_mut(n) {
                Some(peer) => {
                    peer.status = NeighbourStatus::Left;
                    true
                }
                None => false,
            })
            .collect()
    }

    /// Sorts a frame of `neighbour` by the incarnation of the pod that sent it: older than the
    /// newest heard is stale while that pod lives; newer starts the neighbour's ticks afresh.
    /// Once the neighbour is taken for dead (or has left), any other incarnation is its new
    /// pod: one whose clock ran behind its predecessor's (another host's, a Redis server's set
    /// back) is heard after the neighbour timeout rather than never.
    pub(crate) fn incarnation(&mut self, neighbour: ClusterId, incarnation: u64) -> Incarnation {
        let Some(peer) = self.peers.get_mut(&neighbour) else {
            return Incarnation::Current;
        };
        match peer.incarnation {
            Some(newest) if incarnation == newest => Incarnation::Current,
            Some(newest) if incarnation < newest && !peer.status.is_gone() => Incarnation::Stale,
            Some(_) => {
                peer.incarnation = Some(incarnation);
                peer.newest = [None; FrameKind::COUNT];
                Incarnation::Restarted
            }
            None => {
                peer.incarnation = Some(incarnation);
                Incarnation::Current
            }
        }
    }

    /// Whether a frame of a live `neighbour` is tagged no later than one of its frames of the
    /// same kind taken before: a sender publishes one per tick, in order, so it is a replay (or
    /// a forgery of a tick already seen).
    pub(crate) fn replayed(&self, neighbour: ClusterId, tick: u64, kind: FrameKind) -> bool {
        self.peers.get(&neighbour).is_some_and(|peer| {
            peer.status == NeighbourStatus::Alive && peer.newest(kind).is_some_and(|n| tick <= n)
        })
    }

    /// Whether a frame of `neighbour` tagged `tick` is further ahead than any live neighbour
    /// could be, for a cluster at tick `mine` and host time `now_ns`: pods share one schedule,
    /// so a neighbour is at most where this cluster is, or where its own last frame was plus
    /// one tick per `dt` of host time since (this cluster may be the one that stalled), plus
    /// twice the neighbour timeout of slack. Such a frame could only be forged, and would
    /// otherwise pass for the newest; it is dropped.
    pub(crate) fn implausible(
        &self,
        config: &ClusterConfig,
        neighbour: ClusterId,
        tick: u64,
        mine: u64,
        now_ns: u64,
    ) -> bool {
        let window = config.neighbour_timeout_ticks.saturating_mul(2);
        if window == 0 {
            return false;
        }
        let dt_ns = (f64::from(config.dt) * 1e9).max(1.0);
        self.peers.get(&neighbour).is_some_and(|peer| {
            let elapsed = (now_ns.saturating_sub(peer.heard_ns) as f64 / dt_ns) as u64;
            peer.status == NeighbourStatus::Alive
                && peer
                    .newest
                    .iter()
                    .copied()
                    .max()
                    .flatten()
                    .is_some_and(|newest| {
                        tick > newest
                            .saturating_add(elapsed)
                            .max(mine)
                            .saturating_add(window)
                    })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_neighbour() -> (Neighbours, ClusterId) {
        let neighbour = ClusterId::random();
        let config = ClusterConfig::new(ClusterId::random(), vec![neighbour], "shm");
        (Neighbours::new(&config), neighbour)
    }

    #[test]
    fn an_older_pod_is_stale_while_the_newer_lives_and_a_new_one_restarts_the_count() {
        let (mut n, a) = one_neighbour();
        assert_eq!(n.incarnation(a, 100), Incarnation::Current);
        assert_eq!(n.incarnation(a, 100), Incarnation::Current);
        assert_eq!(n.incarnation(a, 99), Incarnation::Stale);
        n.heard(a, 50, FrameKind::Replication, 1, 0);
        assert_eq!(n.incarnation(a, 200), Incarnation::Restarted);
        assert!(
            !n.replayed(a, 3, FrameKind::Replication),
            "its ticks count afresh"
        );
        assert_eq!(n.incarnation(a, 100), Incarnation::Stale);
        assert_eq!(n.incarnation(ClusterId::random(), 1), Incarnation::Current);
    }

    #[test]
    fn once_taken_for_dead_a_pod_with_a_clock_behind_is_heard() {
        let (mut n, a) = one_neighbour();
        assert_eq!(n.incarnation(a, 100), Incarnation::Current);
        n.peers.get_mut(&a).expect("a peer").status = NeighbourStatus::Dead;
        assert_eq!(n.incarnation(a, 40), Incarnation::Restarted);
        n.peers.get_mut(&a).expect("a peer").status = NeighbourStatus::Alive;
        assert_eq!(n.incarnation(a, 40), Incarnation::Current);
        assert_eq!(n.incarnation(a, 39), Incarnation::Stale);
    }
}
