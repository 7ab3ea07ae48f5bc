//! [`Cluster`]: one cluster's world joined to a transport, ticking through the three layers.

use std::time::{Duration, Instant};

use seam_sim::wire::{
    self, ClusterId, ContactReport, EntityId, EntityState, IdMap, PhysicsEventsFrame, PhysicsOp,
    ReplicationFrame, RoutedOp, SeamImpulseReport,
};
use seam_sim::{
    BodyRole, ClusterSim, ContactEvent, PhysicsHandle, SimConfig, SimError, TickContext,
    WriteRouter,
};
use seam_transport::Transport;

use crate::adoption;
use crate::authority::{AuthorityMode, AuthorityPolicy, AuthorityView, NeighbourView, Spatial};
use crate::channels::{self, Channel};
use crate::clock::{OpTiming, monotonic_ns};
use crate::config::{ClusterConfig, CustomProxy, ProxyMode, Region};
use crate::contact_merge::ContactMerge;
use crate::dead_reckoning;
use crate::error::ClusterError;
use crate::inbox::{Inbox, TickFrames};
use crate::interest::{Interest, extent};
use crate::prediction::Predictions;
use crate::settle::{HALF_WAITS_TICKS, Settlement};
use crate::stats::ClusterStats;

/// How long before its last tick a pod stops the policy's hand-offs (see
/// [`Cluster::stop_policy_handoffs`]), seconds: pods on one schedule are a few ticks apart,
/// and a pod that fell behind catches up within a fraction of this.
pub const DRAIN_S: f64 = 0.5;

/// Writes on remote-owned entities, queued by owner until the tick publishes.
struct Outbox<'a> {
    neighbours: &'a [ClusterId],
    ops: &'a mut IdMap<ClusterId, Vec<RoutedOp>>,
    tick: u64,
}

impl WriteRouter for Outbox<'_> {
    fn route(&mut self, owner: ClusterId, op: PhysicsOp) -> Result<(), SimError> {
        if !self.neighbours.contains(&owner) {
            return Err(SimError::NotOwned {
                entity: op.target(),
                owner,
            });
        }
        self.ops.entry(owner).or_default().push(RoutedOp {
            op,
            issued_ns: monotonic_ns(),
            issued_tick: self.tick,
            forwarded: false,
        });
        Ok(())
    }
}

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
}

/// What a cluster tracks of one neighbour.
#[derive(Debug, Clone, Copy)]
struct Peer {
    status: NeighbourStatus,
    /// This cluster's tick when it last heard from the neighbour.
    heard_at: u64,
    /// The highest tick of the neighbour's replication frames taken so far.
    newest_replication: Option<u64>,
    /// The same for its physics-events frames.
    newest_events: Option<u64>,
    /// Host monotonic time of its last frame taken, ns.
    heard_ns: u64,
}

/// Ticks a hand-off this cluster made is remembered (see `Cluster::released`): long after any
/// repeat of an older one can still be in flight.
const RELEASED_FOR: u64 = 600;

/// Room for a physics-events frame when advertising (about 80 ops; larger frames grow it).
const EVENTS_ROOM: usize = 4096;

/// Op timings kept between two [`Cluster::take_op_timings`] calls.
pub const MAX_OP_TIMINGS: usize = 1 << 20;

/// One simulation cluster: its world, its transport, and the three cross-cluster layers.
pub struct Cluster {
    config: ClusterConfig,
    sim: ClusterSim,
    transport: Box<dyn Transport>,
    inbox: Inbox,
    /// Routed writes by destination, for this tick's publish.
    outgoing_ops: IdMap<ClusterId, Vec<RoutedOp>>,
    /// Stage times of the routed ops applied here, until the caller takes them.
    op_timings: Vec<OpTiming>,
    /// Contacts with proxies, by the proxy's owner, for this tick's publish.
    outgoing_contacts: IdMap<ClusterId, Vec<ContactReport>>,
    /// Entities to hand over at the next replication frame, and to whom.
    transfers: IdMap<EntityId, ClusterId>,
    /// Hand-offs not yet answered: the state each carried (new owner, final pose, next epoch).
    /// Every replication frame repeats them until a frame of the new owner mentions the entity,
    /// so a hand-off survives a lost frame (a neighbour that stalled past its buffer misses
    /// some); until then the new owner's silence about the entity is not a departure.
    handed: IdMap<EntityId, EntityState>,
    /// Entities this cluster handed over, with the epoch they left at and the tick: a repeat of
    /// an older hand-off to this cluster arriving after that is not taken (kept for a while,
    /// see [`RELEASED_FOR`]).
    released: IdMap<EntityId, (u32, u64)>,
    custom_proxy: Option<Box<dyn CustomProxy>>,
    replication_channel: String,
    stats: ClusterStats,
    /// What this cluster knows of each neighbour's liveness.
    liveness: IdMap<ClusterId, Peer>,
    /// The states of each neighbour's last replication frame (kept only with a world map): what
    /// its entities are adopted from if it dies.
    last_states: IdMap<ClusterId, Vec<EntityState>>,
    /// Entities this cluster adopted (or took back from a neighbour that died before taking
    /// them), with the cluster they came from: if it returns and still claims one, it gets it
    /// back.
    adopted: IdMap<EntityId, ClusterId>,
    /// Whether the transport was connected at the last liveness check.
    transport_was_up: bool,
    /// Ticking free-running (`tick`, `wait`) rather than in lock-step: the inbox then keeps
    /// one replication frame per neighbour.
    free_running: bool,
    /// Where neighbour entities are modelled (see `crate::interest`).
    interest: Interest,
    /// The policy asked for hand-offs at each replication frame (see `crate::authority`).
    policy: Option<Box<dyn AuthorityPolicy>>,
    /// Contacts surfaced lately, so each surfaces once (see `crate::contact_merge`).
    contact_merge: ContactMerge,
    /// What contacts across the seam gave this cluster's bodies, by the proxy's owner, for
    /// this tick's publish (see `crate::settle`).
    outgoing_impulses: IdMap<ClusterId, Vec<SeamImpulseReport>>,
    /// Own halves of those impulses not given back yet.
    settlement: Settlement,
    /// Impulses routed by game code, shown on this world's coupled proxies of their targets.
    predictions: Predictions,
}

impl Cluster {
    /// Opens the transport the configuration names and subscribes to the neighbours.
    pub fn new(config: ClusterConfig) -> Result<Self, ClusterError> {
        let transport = seam_transport::open(&config.transport)?;
        Self::with_transport(config, transport)
    }

    /// A cluster on a transport opened by the caller.
    pub fn with_transport(
        config: ClusterConfig,
        mut transport: Box<dyn Transport>,
    ) -> Result<Self, ClusterError> {
        for &neighbour in &config.neighbours {
            transport.subscribe(&channels::replication(neighbour))?;
        }
        transport.subscribe(&channels::physics_events(config.cluster_id))?;
        let sim = ClusterSim::new(SimConfig {
            cluster_id: config.cluster_id,
            dt: config.dt,
            gravity: config.gravity,
            max_linear_velocity: config.max_linear_velocity,
        });
        let liveness = config
            .neighbours
            .iter()
            .map(|&n| {
                let peer = Peer {
                    status: NeighbourStatus::NotHeard,
                    heard_at: 0,
                    newest_replication: None,
                    newest_events: None,
                    heard_ns: 0,
                };
                (n, peer)
            })
            .collect();
        let config_authority = config.authority;
        Ok(Self {
            replication_channel: channels::replication(config.cluster_id),
            interest: Interest::new(config.region, config.spread),
            config,
            sim,
            transport,
            inbox: Inbox::default(),
            outgoing_ops: IdMap::default(),
            op_timings: Vec::new(),
            outgoing_contacts: IdMap::default(),
            transfers: IdMap::default(),
            handed: IdMap::default(),
            released: IdMap::default(),
            custom_proxy: None,
            stats: ClusterStats::default(),
            liveness,
            last_states: IdMap::default(),
            adopted: IdMap::default(),
            transport_was_up: true,
            free_running: false,
            contact_merge: ContactMerge::default(),
            outgoing_impulses: IdMap::default(),
            settlement: Settlement::default(),
            predictions: Predictions::default(),
            policy: match config_authority {
                AuthorityMode::Spatial(settings) => Some(Box::new(Spatial::new(settings))),
                AuthorityMode::Scripted | AuthorityMode::Custom => None,
            },
        })
    }

    /// This cluster's id.
    pub fn id(&self) -> ClusterId {
        self.config.cluster_id
    }

    /// The configuration.
    pub fn config(&self) -> &ClusterConfig {
        &self.config
    }

    /// The world, to read (states, roles, contacts).
    pub fn sim(&self) -> &ClusterSim {
        &self.sim
    }

    /// What the cluster has counted.
    pub fn stats(&self) -> ClusterStats {
        self.stats
    }

    /// What the transport has counted.
    pub fn transport_stats(&self) -> seam_transport::Stats {
        self.transport.stats()
    }

    /// Takes the stage times of the routed ops applied here since the last call (at most
    /// [`MAX_OP_TIMINGS`] are kept between calls; older ones are counted in
    /// [`ClusterStats::op_timings_dropped`]).
    pub fn take_op_timings(&mut self) -> Vec<OpTiming> {
        std::mem::take(&mut self.op_timings)
    }

    /// Carries on the world's tick count from `tick`: a pod restarted into a running world
    /// resumes where the others are, so its frames' ticks stay in line with theirs. Call it
    /// before the first tick.
    pub fn resume_at(&mut self, tick: u64) {
        self.sim.resume_at(tick);
    }

    /// Models the neighbour entities whose extent overlaps `region`, besides those the region,
    /// spread and this cluster's own bodies call for, until tick `until` (inclusive; see
    /// [`ClusterSim::tick`]). Queries in game code see only what the cluster models: watch the
    /// reach of a query before it runs — an entity appears as a proxy once a replication frame
    /// of its owner has been reconciled after this call, so at least
    /// `replication_interval + 1` ticks ahead.
    pub fn watch(&mut self, region: Region, until: u64) {
        self.interest.watch(region, until);
    }

    /// Sets the policy asked for hand-offs at each replication frame (replacing the one
    /// `ClusterConfig::authority` chose; see `crate::authority`).
    pub fn set_authority_policy(&mut self, policy: Box<dyn AuthorityPolicy>) {
        self.policy = Some(policy);
    }

    /// Stops asking the authority policy for hand-offs; game code's hand-offs and the return
    /// of adopted entities still go. A pod about to stop calls it some ticks before its last
    /// ([`DRAIN_S`] is enough on one host), so that every hand-off under way is taken before
    /// its neighbours stop: a hand-off published in a pod's last tick reaches no one once they
    /// have, and its entity ends owned by nobody.
    pub fn stop_policy_handoffs(&mut self) {
        self.policy = None;
    }

    /// Sets the hook that moves proxies in [`ProxyMode::Custom`].
    pub fn set_custom_proxy(&mut self, proxy: Box<dyn CustomProxy>) {
        self.custom_proxy = Some(proxy);
    }

    /// Adds an entity this cluster owns, with `role` (dynamic for what it simulates; Fixed or
    /// kinematic for scenery it moves itself). Its state's `cluster_id` is set to this cluster.
    pub fn spawn_owned(&mut self, state: &EntityState, role: BodyRole) -> Result<(), ClusterError> {
        let state = EntityState {
            cluster_id: self.id(),
            ..*state
        };
        self.sim.spawn(&state, role)?;
        Ok(())
    }

    /// Adds scenery: static level geometry (terrain, floors, walls) that every cluster loads
    /// itself. It is a Fixed body owned by no cluster ([`ClusterId::SCENERY`]): never
    /// replicated, never handed over, never adopted; writes on it are refused, and contacts
    /// with it are nobody's to report. Every cluster of a world must add the same scenery.
    pub fn spawn_scenery(&mut self, state: &EntityState) -> Result<(), ClusterError> {
        let state = EntityState {
            cluster_id: ClusterId::SCENERY,
            ..*state
        };
        self.sim.spawn(&state, BodyRole::Fixed)?;
        Ok(())
    }

    /// Gets the transport ready to publish this cluster's frames, so the first tick does not
    /// pay for setting channels up (on shm: creating services and shared memory, milliseconds
    /// per channel). Call it after spawning the entities the cluster starts with: the
    /// replication channel gets room for a frame of them all, with a quarter to spare.
    pub fn advertise(&mut self) -> Result<(), ClusterError> {
        let me = self.id();
        let owned = self
            .sim
            .entities()
            .filter(|(_, info)| info.cluster_id == me)
            .count();
        let frame = ReplicationFrame {
            from: me,
            tick: 0,
            states: Vec::new(),
        };
        let room = frame.max_encoded_len() + (owned + owned / 4) * wire::MAX_STATE_LEN;
        self.transport.advertise(&self.replication_channel, room)?;
        for &neighbour in &self.config.neighbours {
            self.transport
                .advertise(&channels::physics_events(neighbour), EVENTS_ROOM)?;
        }
        Ok(())
    }

    /// Hands an entity this cluster owns to a neighbour. It happens at the next replication
    /// frame: that frame carries the entity's final pose and velocity with the new owner, this
    /// cluster turns its body into a proxy, and the new owner turns its proxy into the body.
    pub fn transfer_authority(
        &mut self,
        entity: EntityId,
        to: ClusterId,
    ) -> Result<(), ClusterError> {
        let refuse = |reason| ClusterError::Transfer { entity, to, reason };
        let info = self.sim.info(entity).ok_or(refuse("not in this world"))?;
        if info.cluster_id != self.id() {
            return Err(refuse("not owned by this cluster"));
        }
        if to == self.id() {
            return Err(refuse("already owned here"));
        }
        if !self.config.neighbours.contains(&to) {
            return Err(refuse("not a neighbour"));
        }
        if self.neighbour_status(to) == Some(NeighbourStatus::Dead) {
            return Err(refuse("the neighbour is taken for dead (silent)"));
        }
        self.transfers.insert(entity, to);
        Ok(())
    }

    /// One tick using whatever has arrived (free-running pods). A neighbour silent for more
    /// than `neighbour_timeout_ticks` is taken for dead first (see [`NeighbourStatus`]).
    pub fn tick(
        &mut self,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        self.free_running = true;
        self.drain()?;
        self.check_liveness();
        let frames = self.inbox.take_all();
        self.run(frames, user)
    }

    /// What this cluster knows of `neighbour`'s liveness (`None` for a non-neighbour).
    pub fn neighbour_status(&self, neighbour: ClusterId) -> Option<NeighbourStatus> {
        self.liveness.get(&neighbour).map(|peer| peer.status)
    }

    /// Takes neighbours silent for too long for dead: adopts what the rule gives this cluster
    /// of their entities, despawns the rest of their proxies. While this cluster's own
    /// transport is down nobody can be heard, so nobody is taken for dead: the clock of every
    /// neighbour restarts when the transport comes back.
    fn check_liveness(&mut self) {
        let timeout = self.config.neighbour_timeout_ticks;
        if timeout == 0 {
            return;
        }
        let now = self.sim.tick();
        let up = self.transport.is_connected();
        if !up || !self.transport_was_up {
            self.transport_was_up = up;
            let now_ns = monotonic_ns();
            for peer in self.liveness.values_mut() {
                peer.heard_at = now;
                peer.heard_ns = now_ns;
            }
            return;
        }
        // Silent for more than the timeout in ticks *and* in host time (timeout × dt): a pod
        // catching up after a stall runs its ticks back to back, faster than its neighbours
        // publish, and must not take them for dead for that.
        let timeout_ns = (timeout as f64 * f64::from(self.config.dt) * 1e9) as u64;
        let now_ns = monotonic_ns();
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
            self.adopt_from(neighbour);
        }
    }

    /// The entities of `dead`, taken for dead just now: those the adoption rule gives this
    /// cluster become its own, from their last replicated state; those handed to `dead` that
    /// it never took come back; every other proxy of `dead` is despawned (its adopter's frames
    /// bring it back).
    fn adopt_from(&mut self, dead: ClusterId) {
        let me = self.config.cluster_id;
        let last = self.last_states.swap_remove(&dead).unwrap_or_default();
        let liveness = &self.liveness;
        let alive = |c: ClusterId| {
            c == me
                || liveness
                    .get(&c)
                    .is_none_or(|peer| peer.status != NeighbourStatus::Dead)
        };
        for state in last.iter().filter(|s| s.cluster_id == dead) {
            if adoption::adopter(&self.config.world, dead, state.position, alive) != Some(me) {
                continue;
            }
            let adopted = EntityState {
                cluster_id: me,
                ..*state
            };
            let done = match self.sim.info(state.id).map(|i| i.cluster_id) {
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
            .filter(|(_, info)| info.cluster_id == dead)
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
    fn heard(&mut self, neighbour: ClusterId, tick: u64, replication: bool) {
        let now = self.sim.tick();
        if let Some(peer) = self.liveness.get_mut(&neighbour) {
            let back = peer.status == NeighbourStatus::Dead;
            if back {
                // Back, perhaps restarted with a lower tick: its ticks count afresh.
                self.stats.neighbours_rejoined += 1;
                peer.newest_replication = None;
                peer.newest_events = None;
            }
            peer.status = NeighbourStatus::Alive;
            peer.heard_at = now;
            peer.heard_ns = monotonic_ns();
            let newest = if replication {
                &mut peer.newest_replication
            } else {
                &mut peer.newest_events
            };
            *newest = Some(newest.map_or(tick, |t| t.max(tick)));
            if back {
                self.return_adopted(neighbour);
            }
        }
    }

    /// Hands every entity adopted from `neighbour`, which is back, to it again at the next
    /// replication frame: a restarted pod starts empty and gets its entities back; a stalled
    /// one that still simulates them keeps its own copy (a hand-off of an entity it owns
    /// changes nothing there), and this cluster's copy stops.
    fn return_adopted(&mut self, neighbour: ClusterId) {
        let me = self.config.cluster_id;
        let sim = &self.sim;
        let back: Vec<EntityId> = self
            .adopted
            .iter()
            .filter(|&(id, &from)| {
                from == neighbour && sim.info(*id).is_some_and(|i| i.cluster_id == me)
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
    fn replayed(&self, neighbour: ClusterId, tick: u64, replication: bool) -> bool {
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
    fn implausible(&self, neighbour: ClusterId, tick: u64) -> bool {
        let window = self.config.neighbour_timeout_ticks.saturating_mul(2);
        if window == 0 {
            return false;
        }
        let dt_ns = (f64::from(self.config.dt) * 1e9).max(1.0);
        let mine = self.sim.tick();
        self.liveness.get(&neighbour).is_some_and(|peer| {
            let elapsed = (monotonic_ns().saturating_sub(peer.heard_ns) as f64 / dt_ns) as u64;
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

    /// One tick in lock-step: waits (up to `timeout`) until every neighbour's frames from the
    /// same tick have arrived, and uses exactly those, so runs are deterministic on any
    /// transport.
    pub fn tick_lockstep(
        &mut self,
        timeout: Duration,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        self.free_running = false;
        let tick = self.sim.tick();
        if tick > 0 {
            let replication = tick.is_multiple_of(self.config.replication_interval);
            let deadline = Instant::now() + timeout;
            self.drain()?;
            while let Some((neighbour, what)) =
                self.inbox
                    .missing(tick, &self.config.neighbours, replication)
            {
                let now = Instant::now();
                if now >= deadline {
                    return Err(ClusterError::NeighbourSilent {
                        neighbour,
                        what,
                        tick,
                        waited_ms: timeout.as_millis() as u64,
                    });
                }
                if let Some(message) = self.transport.receive_timeout(deadline - now)? {
                    let received_ns = monotonic_ns();
                    let frame = decode_frame(message.channel, message.payload);
                    self.file(frame, received_ns);
                }
                self.drain()?;
            }
        }
        let frames = self.inbox.take_tick(tick, &self.config.neighbours);
        self.run(frames, user)
    }

    /// Waits up to `timeout` for a frame to arrive, sleeping on the transport's wake-up rather
    /// than spinning, and keeps it (with anything else that has arrived) for the next tick.
    /// Returns whether anything arrived. Free-running pods call this between ticks, so frames
    /// are taken off the transport as they come and stamped "received" when they arrive.
    pub fn wait(&mut self, timeout: Duration) -> Result<bool, ClusterError> {
        self.free_running = true;
        let Some(message) = self.transport.receive_timeout(timeout)? else {
            return Ok(false);
        };
        let received_ns = monotonic_ns();
        let frame = decode_frame(message.channel, message.payload);
        self.file(frame, received_ns);
        self.drain()?;
        Ok(true)
    }

    /// Moves everything the transport holds into the inbox.
    fn drain(&mut self) -> Result<(), ClusterError> {
        while let Some(message) = self.transport.try_receive()? {
            let received_ns = monotonic_ns();
            // Decoded straight from the received bytes (on shm, the shared-memory sample).
            let frame = decode_frame(message.channel, message.payload);
            self.file(frame, received_ns);
        }
        Ok(())
    }

    fn file(&mut self, frame: Result<Frame, Rejected>, received_ns: u64) {
        let kept = match frame {
            Ok(frame) if self.implausible(frame.from(), frame.tick()) => {
                self.stats.frames_implausible += 1;
                return;
            }
            Ok(frame) if self.replayed(frame.from(), frame.tick(), frame.is_replication()) => None,
            Ok(Frame::Replication(frame)) if self.config.neighbours.contains(&frame.from) => {
                let from = (frame.from, frame.tick, true);
                let kept = if self.free_running {
                    self.inbox.add_replication_newest(frame)
                } else {
                    self.inbox.add_replication(frame)
                };
                kept.then_some(from)
            }
            Ok(Frame::Events(frame)) if self.config.neighbours.contains(&frame.from) => {
                let from = (frame.from, frame.tick, false);
                self.inbox.add_events(frame, received_ns).then_some(from)
            }
            Ok(_) | Err(Rejected::WrongSender) => {
                self.stats.frames_wrong_sender += 1;
                return;
            }
            Err(Rejected::Undecodable) => {
                self.stats.frames_malformed += 1;
                return;
            }
            Err(Rejected::WrongVersion) => {
                self.stats.frames_wrong_version += 1;
                return;
            }
        };
        match kept {
            Some((from, tick, replication)) => {
                self.stats.frames_accepted += 1;
                self.heard(from, tick, replication);
            }
            None => self.stats.frames_replayed += 1,
        }
    }

    fn run(
        &mut self,
        frames: TickFrames,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        // Reconcile the world with what the neighbours replicated.
        self.interest.expire(self.sim.tick());
        let keep_last = !self.config.world.is_empty();
        for frame in frames.replication {
            self.reconcile(&frame);
            if keep_last {
                self.last_states.insert(frame.from, frame.states);
            }
        }
        // Each contact once per side (see `crate::contact_merge`): this world's own events,
        // then the neighbours' reports.
        let tick = self.sim.tick();
        let merge = &mut self.contact_merge;
        merge.expire(tick);
        let mut merged = 0;
        self.sim.retain_contacts(|c| {
            let new = merge.is_new(c, tick, true);
            merged += u64::from(!new);
            new
        });
        let mut reported = Vec::new();
        for (frame, _) in &frames.events {
            for c in &frame.contacts {
                self.stats.contacts_received += 1;
                let event = ContactEvent {
                    a: c.a,
                    b: c.b,
                    started: c.started,
                    impulse: c.impulse,
                    normal: c.normal,
                    reported_by: Some(frame.from),
                };
                if merge.is_new(&event, tick, false) {
                    reported.push(event);
                } else {
                    merged += 1;
                }
            }
        }
        self.stats.contacts_merged += merged;
        self.sim.add_contacts(reported);

        // User code; writes on remote-owned entities go to the outbox.
        let mut outbox = Outbox {
            neighbours: &self.config.neighbours,
            ops: &mut self.outgoing_ops,
            tick: self.sim.tick(),
        };
        self.sim.run_user(&mut outbox, user);
        let tick = self.sim.tick();
        if self.config.coupling {
            self.predictions
                .routed(self.outgoing_ops.values().flatten(), tick);
        }

        // Contacts across the seam settled (see `crate::settle`), then routed writes received,
        // all applied just before the step.
        self.settle_seam_impulses(&frames.events, tick);
        for (frame, received_ns) in &frames.events {
            for routed in &frame.ops {
                if let Some(v) = routed.op.vector()
                    && v.iter().all(|c| c.is_finite())
                    && !within(v, self.config.max_magnitude)
                {
                    self.stats.ops_dropped_absurd += 1;
                    continue;
                }
                match self.sim.info(routed.op.target()) {
                    // Handed over since the issuer routed it: sent on, once, to the owner this
                    // cluster knows.
                    Some(info)
                        if info.cluster_id != self.config.cluster_id
                            && !routed.forwarded
                            && self.config.neighbours.contains(&info.cluster_id)
                            && self.neighbour_status(info.cluster_id)
                                != Some(NeighbourStatus::Dead) =>
                    {
                        self.outgoing_ops
                            .entry(info.cluster_id)
                            .or_default()
                            .push(RoutedOp {
                                forwarded: true,
                                ..*routed
                            });
                        self.stats.ops_forwarded += 1;
                    }
                    Some(info) if info.cluster_id == self.config.cluster_id => {
                        match self.sim.apply_op(&routed.op) {
                            Ok(()) => {
                                self.stats.ops_applied += 1;
                                let timing = OpTiming {
                                    issued_ns: routed.issued_ns,
                                    published_ns: frame.published_ns,
                                    received_ns: *received_ns,
                                    applied_ns: monotonic_ns(),
                                    issued_tick: routed.issued_tick,
                                    applied_tick: tick,
                                };
                                if self.op_timings.len() < MAX_OP_TIMINGS {
                                    self.op_timings.push(timing);
                                } else {
                                    self.stats.op_timings_dropped += 1;
                                }
                            }
                            Err(_) => self.stats.ops_dropped_invalid += 1,
                        }
                    }
                    _ => self.stats.ops_dropped_not_owner += 1,
                }
            }
        }

        if self.config.coupling && self.config.proxy_mode != ProxyMode::Custom {
            let changes = self.sim.couple_proxies(self.proxy_role());
            self.stats.proxies_coupled += u64::from(changes.coupled);
            let interval = self.config.replication_interval.max(1);
            self.stats.impulses_predicted += self.predictions.show(&mut self.sim, tick, interval);
        }
        self.sim.step();
        self.report_contacts();
        self.report_seam_impulses();
        self.publish()?;
        self.stats.ticks += 1;
        Ok(())
    }

    fn proxy_role(&self) -> BodyRole {
        match self.config.proxy_mode {
            ProxyMode::Fixed => BodyRole::Fixed,
            ProxyMode::KinematicVelocityBased => BodyRole::KinematicVelocityBased,
            ProxyMode::Custom => BodyRole::KinematicPositionBased,
        }
    }

    /// How long a replicated pose stands before the next frame can replace it, seconds: the
    /// sweep an extent is grown by (see `crate::interest`).
    fn sweep_s(&self) -> f32 {
        (self.config.replication_interval.max(1) + 1) as f32 * self.config.dt
    }

    fn visible(&self, state: &EntityState) -> bool {
        self.interest.covers(&extent(state, self.sweep_s()))
    }

    /// Brings the world in line with one neighbour's replication frame.
    fn reconcile(&mut self, frame: &ReplicationFrame) {
        let (me, from) = (self.config.cluster_id, frame.from);
        let mut listed: IdMap<EntityId, ()> = IdMap::default();
        // A hand-off this cluster made to `from` is answered once `from` mentions the entity.
        if self.handed.values().any(|handed| handed.cluster_id == from) {
            let mentioned: IdMap<EntityId, ()> = frame.states.iter().map(|s| (s.id, ())).collect();
            self.handed
                .retain(|id, handed| handed.cluster_id != from || !mentioned.contains_key(id));
        }
        for state in &frame.states {
            let limit = self.config.max_magnitude;
            let absurd = ![state.position, state.linvel, state.angvel]
                .into_iter()
                .all(|v| within(v, limit));
            if absurd || seam_sim::check_state(state).is_err() {
                self.stats.states_rejected += 1;
                continue;
            }
            let known = self.sim.info(state.id).map(|i| (i.cluster_id, i.epoch));
            let outcome = match known {
                // Handed (back) to this cluster, which owns it already — a repeat, or a return
                // to a pod that was only stalled and kept simulating it: nothing to do but
                // learn the epoch.
                Some((owner, epoch)) if owner == me && state.cluster_id == me => {
                    if state.epoch > epoch {
                        let _ = self.sim.set_authority(state.id, me, state.epoch);
                    }
                    Ok(())
                }
                // Older than what this world knows (a hand-off repeated after the entity moved
                // on): not news.
                Some((_, epoch)) if state.epoch < epoch => Ok(()),
                // A repeat of the hand-off this world already applied.
                Some((owner, epoch))
                    if owner != from && state.epoch == epoch && state.cluster_id == owner =>
                {
                    Ok(())
                }
                // Only an entity's owner speaks for it: a frame claiming another cluster's
                // (or this cluster's) entity is ignored.
                Some((owner, _)) if owner != from => Err(()),
                Some(_) => {
                    listed.insert(state.id, ());
                    self.update_known(state, from)
                }
                None if state.cluster_id == me => {
                    let released = self.released.get(&state.id);
                    if released.is_some_and(|&(epoch, _)| state.epoch <= epoch) {
                        // A repeat of a hand-off to this cluster from before it gave the entity
                        // away again.
                        Ok(())
                    } else {
                        self.take_over_unseen(state)
                    }
                }
                None if state.cluster_id == from && self.visible(state) => {
                    listed.insert(state.id, ());
                    let role = self.proxy_role();
                    self.sim
                        .spawn(state, role)
                        .map(|()| self.stats.proxies_spawned += 1)
                        .map_err(|_| ())
                }
                None => Ok(()),
            };
            if outcome.is_err() {
                self.stats.states_rejected += 1;
            }
        }
        // Proxies of this neighbour that its frame no longer lists have left (or were
        // destroyed): nothing else is modelled.
        let departed: Vec<EntityId> = self
            .sim
            .entities()
            .filter(|(id, info)| info.cluster_id == from && !listed.contains_key(id))
            .filter(|(id, _)| !self.handed.contains_key(id))
            .map(|(id, _)| id)
            .collect();
        for id in departed {
            if self.sim.despawn(id).is_ok() {
                self.stats.proxies_despawned += 1;
            }
        }
    }

    /// A state from the current owner of an entity this world already has.
    fn update_known(&mut self, state: &EntityState, from: ClusterId) -> Result<(), ()> {
        let me = self.config.cluster_id;
        if state.cluster_id == me {
            // Handed to this cluster: the proxy becomes the body, in place, with the final pose
            // and velocity the old owner sent.
            self.sim
                .set_role(state.id, owner_role(state))
                .map_err(|_| ())?;
            self.sim.apply_state(state).map_err(|_| ())?;
            self.stats.handoffs_in += 1;
            return Ok(());
        }
        if state.cluster_id != from {
            // Handed to a third cluster: writes are routed there from now on.
            self.sim
                .set_authority(state.id, state.cluster_id, state.epoch)
                .map_err(|_| ())?;
        }
        if !self.visible(state) {
            self.sim.despawn(state.id).map_err(|_| ())?;
            self.stats.proxies_despawned += 1;
            return Ok(());
        }
        self.update_proxy(state)
    }

    /// Handed to this cluster an entity it had no proxy of: it starts as the body.
    fn take_over_unseen(&mut self, state: &EntityState) -> Result<(), ()> {
        self.sim.spawn(state, owner_role(state)).map_err(|_| ())?;
        self.stats.handoffs_in += 1;
        Ok(())
    }

    fn update_proxy(&mut self, state: &EntityState) -> Result<(), ()> {
        self.predictions.state_applied(state.id);
        let coupled = self
            .sim
            .info(state.id)
            .is_some_and(|info| info.role == BodyRole::Dynamic);
        if coupled {
            // Simulated here for now (see `seam_sim::coupling`): set to what its owner says.
            return self.sim.apply_state(state).map_err(|_| ());
        }
        match self.config.proxy_mode {
            ProxyMode::Fixed => self.sim.apply_state(state).map_err(|_| ()),
            ProxyMode::KinematicVelocityBased => {
                // Aim where the entity will be at the next update, so the proxy moves with it in
                // between (see `crate::dead_reckoning`).
                let now = self.sim.state(state.id).ok_or(())?;
                let ticks = self.config.replication_interval.max(1) as f32;
                let aim = dead_reckoning::aim(&now, state, self.config.dt * ticks, ticks);
                self.sim.apply_state(&aim).map_err(|_| ())
            }
            ProxyMode::Custom => match self.custom_proxy.as_mut() {
                Some(proxy) => proxy.update(&mut self.sim, state).map_err(|_| ()),
                None => self.sim.apply_state(state).map_err(|_| ()),
            },
        }
    }

    /// Contacts of the last step between a body owned here and a proxy go to the proxy's owner.
    fn report_contacts(&mut self) {
        let me = self.config.cluster_id;
        let tick = self.sim.tick();
        for contact in self
            .sim
            .contacts()
            .iter()
            .filter(|c| c.reported_by.is_none())
        {
            let owner = |id| self.sim.info(id).map(|i| i.cluster_id);
            let (Some(owner_a), Some(owner_b)) = (owner(contact.a), owner(contact.b)) else {
                continue;
            };
            let destination = match (owner_a == me, owner_b == me) {
                (true, false) => owner_b,
                (false, true) => owner_a,
                _ => continue,
            };
            if !self.config.neighbours.contains(&destination) {
                // Scenery: nobody's to report to.
                continue;
            }
            self.outgoing_contacts
                .entry(destination)
                .or_default()
                .push(ContactReport {
                    a: contact.a,
                    b: contact.b,
                    started: contact.started,
                    tick,
                    impulse: contact.impulse,
                    normal: contact.normal,
                });
            self.stats.contacts_sent += 1;
        }
    }

    /// What contacts across the seam gave this cluster's bodies in the last step: noted for
    /// settling, and sent to each proxy's owner.
    fn report_seam_impulses(&mut self) {
        if !self.config.coupling {
            return;
        }
        let tick = self.sim.tick();
        let impulses = self.sim.seam_impulses();
        for i in &impulses {
            let Some(owner) = self.sim.info(i.proxy).map(|info| info.cluster_id) else {
                continue;
            };
            if self.config.neighbours.contains(&owner) {
                self.outgoing_impulses
                    .entry(owner)
                    .or_default()
                    .push(SeamImpulseReport {
                        own: i.own,
                        other: i.proxy,
                        impulse: i.impulse,
                        tick,
                    });
                self.stats.seam_impulses_sent += 1;
            }
        }
        self.settlement.record(tick, &impulses);
    }

    /// Gives this cluster's bodies back half of what each world's contact across the seam gave
    /// them (see `crate::settle`), as impulses. Reports naming a body this cluster does not
    /// simulate (handed on since), or with values that are not finite or beyond
    /// `max_magnitude`, change nothing and are counted.
    fn settle_seam_impulses(&mut self, events: &[(PhysicsEventsFrame, u64)], tick: u64) {
        let me = self.config.cluster_id;
        let limit = self.config.max_magnitude;
        let mut received = Vec::new();
        for (frame, _) in events {
            for report in &frame.impulses {
                self.stats.seam_impulses_received += 1;
                let simulated_here = self
                    .sim
                    .info(report.other)
                    .is_some_and(|i| i.cluster_id == me && i.role == BodyRole::Dynamic);
                if simulated_here && within(report.impulse, limit) {
                    received.push(*report);
                } else {
                    self.stats.seam_impulses_dropped += 1;
                }
            }
        }
        let wait = if self.free_running {
            HALF_WAITS_TICKS
        } else {
            0
        };
        let settled = self.settlement.settle(received, tick, wait);
        self.stats.seam_impulses_disagreed += settled.disagreed;
        self.stats.seam_impulses_unmatched += settled.unmatched;
        for &(step, _, other, impulse) in &settled.unanswered {
            // A contact the other world did not see: the push it would have given the other
            // body goes to that body's owner. Only if the owner is alive and has published its
            // reports of that step: silence from a pod that stalled or died says nothing of
            // what it saw, and the push would be lost with it.
            let Some(owner) = self.sim.info(other).map(|i| i.cluster_id) else {
                continue;
            };
            if owner == me || !self.config.neighbours.contains(&owner) {
                continue;
            }
            let reported_step = self.liveness.get(&owner).is_some_and(|peer| {
                peer.status == NeighbourStatus::Alive
                    && peer.newest_events.is_some_and(|newest| newest >= step)
            });
            if !reported_step {
                self.stats.seam_impulses_unjudged += 1;
                continue;
            }
            self.outgoing_ops.entry(owner).or_default().push(RoutedOp {
                op: PhysicsOp::Impulse {
                    target: other,
                    impulse: impulse.map(|c| -c),
                },
                issued_ns: monotonic_ns(),
                issued_tick: tick,
                forwarded: false,
            });
            self.stats.seam_impulses_routed += 1;
        }
        for (target, impulse) in settled.impulses {
            let simulated_here = self
                .sim
                .info(target)
                .is_some_and(|i| i.cluster_id == me && i.role == BodyRole::Dynamic);
            if simulated_here
                && self
                    .sim
                    .apply_op(&PhysicsOp::Impulse { target, impulse })
                    .is_ok()
            {
                self.stats.seam_impulses_settled += 1;
            }
        }
    }

    /// Asks the authority policy which of the `owned` entities to hand over in this frame, and
    /// queues those hand-offs that are valid and not already queued by game code.
    fn ask_policy(&mut self, owned: &[(EntityState, BodyRole)]) {
        let Some(policy) = self.policy.as_mut() else {
            return;
        };
        let neighbours: Vec<NeighbourView> = self
            .config
            .neighbours
            .iter()
            .map(|&id| NeighbourView {
                id,
                region: self
                    .config
                    .world
                    .iter()
                    .find(|c| c.id == id)
                    .map(|c| c.region),
                alive: self
                    .liveness
                    .get(&id)
                    .is_none_or(|peer| peer.status != NeighbourStatus::Dead),
            })
            .collect();
        // Adopted entities stay in custody until their owner returns and gets them back.
        let custody: Vec<(EntityState, BodyRole)>;
        let owned = if self.adopted.is_empty() {
            owned
        } else {
            custody = owned
                .iter()
                .filter(|(state, _)| !self.adopted.contains_key(&state.id))
                .copied()
                .collect();
            &custody
        };
        let view = AuthorityView {
            cluster: self.config.cluster_id,
            tick: self.sim.tick(),
            region: self.config.region,
            lookahead_s: self.config.dt * self.config.replication_interval.max(1) as f32,
            neighbours: &neighbours,
            owned,
        };
        let mut handoffs = Vec::new();
        policy.decide(&view, &mut handoffs);
        for (entity, to) in handoffs {
            if self.transfers.contains_key(&entity) {
                continue;
            }
            if self.transfer_authority(entity, to).is_ok() {
                self.stats.handoffs_by_policy += 1;
            }
        }
    }

    /// Publishes this tick's replication frame (every `replication_interval` ticks, with any
    /// hand-offs) and one events frame per neighbour.
    fn publish(&mut self) -> Result<(), ClusterError> {
        let me = self.config.cluster_id;
        let tick = self.sim.tick();
        if tick.is_multiple_of(self.config.replication_interval) {
            let owned: Vec<(EntityState, BodyRole)> = self
                .sim
                .entities()
                .filter(|(_, info)| info.cluster_id == me)
                .filter_map(|(id, info)| self.sim.state(id).map(|s| (s, info.role)))
                .collect();
            self.ask_policy(&owned);
            let mut states: Vec<EntityState> = owned.into_iter().map(|(s, _)| s).collect();
            let mut handing = Vec::new();
            for state in &mut states {
                if let Some(&to) = self.transfers.get(&state.id) {
                    // The new owner rides with the final pose and velocity, read before the body
                    // becomes a proxy (a Fixed body loses its velocity), and the next epoch.
                    state.cluster_id = to;
                    state.epoch += 1;
                    handing.push(*state);
                }
            }
            let (sweep_s, spread) = (self.sweep_s(), self.config.spread);
            self.interest.follow(
                states.iter().filter(|s| s.cluster_id == me),
                sweep_s,
                spread,
            );
            // Earlier hand-offs not yet answered ride along again.
            states.extend(self.handed.values().copied());
            let frame = ReplicationFrame {
                from: me,
                tick,
                states,
            };
            self.stats.replication_bytes +=
                publish_frame(self.transport.as_mut(), &self.replication_channel, &frame)? as u64;
            let role = self.proxy_role();
            self.transfers.clear();
            for handed in handing {
                let entity = handed.id;
                self.adopted.swap_remove(&entity);
                self.sim
                    .set_authority(entity, handed.cluster_id, handed.epoch)?;
                self.sim.set_role(entity, role)?;
                self.handed.insert(entity, handed);
                self.released.insert(entity, (handed.epoch, tick));
                self.stats.handoffs_out += 1;
            }
            self.released
                .retain(|_, &mut (_, at)| tick.saturating_sub(at) <= RELEASED_FOR);
        }
        for i in 0..self.config.neighbours.len() {
            let neighbour = self.config.neighbours[i];
            let mut ops = self
                .outgoing_ops
                .get_mut(&neighbour)
                .map(std::mem::take)
                .unwrap_or_default();
            if self.neighbour_status(neighbour) == Some(NeighbourStatus::Dead) {
                // Taken for dead: its entities are adopted or gone, so writes queued for it
                // (before it was) have no owner there. The empty frame still tells it, should it
                // be alive after all, that this cluster is.
                self.stats.ops_dropped_owner_dead += ops.len() as u64;
                ops.clear();
            }
            let frame = PhysicsEventsFrame {
                from: me,
                tick,
                published_ns: monotonic_ns(),
                ops,
                contacts: self
                    .outgoing_contacts
                    .get_mut(&neighbour)
                    .map(std::mem::take)
                    .unwrap_or_default(),
                impulses: self
                    .outgoing_impulses
                    .get_mut(&neighbour)
                    .map(std::mem::take)
                    .unwrap_or_default(),
            };
            self.stats.ops_routed += frame.ops.len() as u64;
            self.stats.events_bytes += publish_frame(
                self.transport.as_mut(),
                &channels::physics_events(neighbour),
                &frame,
            )? as u64;
        }
        Ok(())
    }
}

/// The role an entity's owner gives its body: dynamic if it is simulated, else Fixed (a body
/// its old owner moved itself stands still until game code here moves it).
fn owner_role(state: &EntityState) -> BodyRole {
    if state.body.simulated {
        BodyRole::Dynamic
    } else {
        BodyRole::Fixed
    }
}

enum Frame {
    Replication(ReplicationFrame),
    Events(PhysicsEventsFrame),
}

impl Frame {
    fn from(&self) -> ClusterId {
        match self {
            Frame::Replication(f) => f.from,
            Frame::Events(f) => f.from,
        }
    }

    fn tick(&self) -> u64 {
        match self {
            Frame::Replication(f) => f.tick,
            Frame::Events(f) => f.tick,
        }
    }

    fn is_replication(&self) -> bool {
        matches!(self, Frame::Replication(_))
    }
}

/// Why a received frame was not taken.
enum Rejected {
    /// The bytes are not a frame of the channel's kind.
    Undecodable,
    /// A frame of another wire format version.
    WrongVersion,
    /// A replication frame whose sender is not the cluster its channel names, or a message on
    /// a channel that is not one of seam's.
    WrongSender,
}

fn rejected(error: wire::WireError) -> Rejected {
    match error {
        wire::WireError::Version { .. } => Rejected::WrongVersion,
        _ => Rejected::Undecodable,
    }
}

/// Decodes a received frame straight from the received bytes.
fn decode_frame(channel: &str, payload: &[u8]) -> Result<Frame, Rejected> {
    match channels::parse(channel).ok_or(Rejected::WrongSender)? {
        Channel::Replication(from) => {
            let frame = wire::decode::<ReplicationFrame>(payload).map_err(rejected)?;
            if frame.from != from {
                return Err(Rejected::WrongSender);
            }
            Ok(Frame::Replication(frame))
        }
        Channel::PhysicsEvents(_) => wire::decode::<PhysicsEventsFrame>(payload)
            .map(Frame::Events)
            .map_err(rejected),
    }
}

/// Whether every component of `v` is within `limit` in magnitude (NaN is not).
fn within(v: [f32; 3], limit: f32) -> bool {
    v.iter().all(|c| c.abs() <= limit)
}

/// Encodes `frame` straight into the transport's buffer (on shm, the loaned sample); returns
/// the encoded length.
fn publish_frame<T: serde::Serialize>(
    transport: &mut dyn Transport,
    channel: &str,
    frame: &T,
) -> Result<usize, ClusterError> {
    let len = wire::encoded_len(frame);
    transport.publish_with(channel, len, &mut |buffer| {
        wire::encode_into(frame, buffer).ok()
    })?;
    Ok(len)
}
