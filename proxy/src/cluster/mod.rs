//! [`Cluster`]: one cluster's world joined to a transport, ticking through the three layers.

use std::sync::Arc;
use std::time::{Duration, Instant};

use seam_sim::wire::{
    self, ClusterId, ContactReport, EntityId, EntityState, IdMap, OpAck, PhysicsEventsFrame,
    ReplicationEncoder, ReplicationFrame, RoutedOp, SeamImpulseReport,
};
use seam_sim::{BodyRole, ClusterSim, PhysicsHandle, SimConfig, TickContext};
use seam_transport::Transport;

use crate::authority::{AuthorityMode, AuthorityPolicy, Spatial};
use crate::channels;
use crate::clock::{OpTiming, monotonic_ns};
use crate::config::{ClusterConfig, CustomProxy, ProxyMode, Region};
use crate::contact_merge::ContactMerge;
use crate::delivery::{OpKey, Outstanding, Settled};
use crate::error::ClusterError;
use crate::inbox::{HeldReplication, Inbox, TickFrames};
use crate::interest::Interest;
use crate::keyframes::Keyframes;
use crate::ledger::{Carried, LedgerEntry, LedgerEvent};
use crate::prediction::Predictions;
use crate::settle::Settlement;
use crate::stats::ClusterStats;

mod contacts;
mod liveness;
mod publish;
mod receive;
mod reconcile;
mod routing;

pub use liveness::NeighbourStatus;
use liveness::Peer;
use receive::decode_frame;
use reconcile::owner_role;
use routing::Outbox;

/// How long before its last tick a pod stops the policy's hand-offs (see
/// [`Cluster::stop_policy_handoffs`]), seconds: pods on one schedule are a few ticks apart,
/// and a pod that fell behind catches up within a fraction of this.
pub const DRAIN_S: f64 = 0.5;

/// Ticks a hand-off this cluster made is remembered (see `Cluster::released`): long after any
/// repeat of an older one can still be in flight.
const RELEASED_FOR: u64 = 600;

/// Room for a physics-events frame when advertising (about 80 ops; larger frames grow it).
const EVENTS_ROOM: usize = 4096;

/// Op timings kept between two [`Cluster::take_op_timings`] calls.
pub const MAX_OP_TIMINGS: usize = 1 << 20;

/// A hand-off as one cluster saw it (see [`Cluster::take_handoffs`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HandoffEvent {
    /// The entity.
    pub entity: EntityId,
    /// Taken by this cluster (else given away).
    pub taken: bool,
}

/// One simulation cluster: its world, its transport, and the three cross-cluster layers.
pub struct Cluster {
    config: ClusterConfig,
    sim: ClusterSim,
    transport: Box<dyn Transport>,
    inbox: Inbox,
    /// Routed writes by destination, for this tick's publish.
    outgoing_ops: IdMap<ClusterId, Vec<RoutedOp>>,
    /// Answers to the ops received, by their sender, for this tick's publish.
    outgoing_acks: IdMap<ClusterId, Vec<OpAck>>,
    /// The number the next op issued (or contact reported) here gets (see `crate::delivery`).
    next_op_seq: u64,
    /// Ops sent and not answered yet (see `crate::delivery`).
    outstanding: Outstanding<RoutedOp>,
    /// Contact reports sent and not answered yet.
    outstanding_contacts: Outstanding<ContactReport>,
    /// Op numbers settled here, per issuer (see `crate::delivery`).
    settled: Settled,
    /// Stage times of the routed ops applied here, until the caller takes them.
    op_timings: Vec<OpTiming>,
    /// Hand-offs taken and given here, until the caller takes them.
    handoff_log: Vec<HandoffEvent>,
    /// What became of each op and contact report here, until the caller takes it; `None`
    /// unless asked for (see [`Cluster::keep_ledger`]).
    ledger: Option<Vec<LedgerEntry>>,
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
    /// Hand-offs to this cluster whose state is from a later tick than this world's
    /// (free-running: the old owner ticked after this cluster's last tick and before this
    /// one), with the cluster that sent each: taken at the tick the state belongs to, so the
    /// body is not stepped twice for one tick.
    early_handoffs: IdMap<EntityId, (EntityState, ClusterId)>,
    custom_proxy: Option<Box<dyn CustomProxy>>,
    replication_channel: String,
    /// Tables reused by every replication frame this cluster encodes.
    encoder: ReplicationEncoder,
    /// The last keyframe this cluster sent, for the delta frames after it.
    keyframes: Keyframes,
    /// Each neighbour's last keyframe received, with its tick: what its delta frames are read
    /// against.
    keys: IdMap<ClusterId, (u64, Arc<[u8]>)>,
    /// The owned states and roles gathered for the last replication frame, and its states:
    /// buffers kept for the next.
    scratch_owned: Vec<(EntityState, BodyRole)>,
    scratch_states: Vec<EntityState>,
    stats: ClusterStats,
    /// What this cluster knows of each neighbour's liveness.
    liveness: IdMap<ClusterId, Peer>,
    /// The states of each neighbour's last replication frame (kept only with a world map): what
    /// its entities are adopted from if it dies.
    last_states: IdMap<ClusterId, HeldReplication>,
    /// Entities this cluster adopted (or took back from a neighbour that died before taking
    /// them), with the cluster they came from: if it returns and still claims one, it gets it
    /// back.
    adopted: IdMap<EntityId, ClusterId>,
    /// Whether the transport was connected at the last liveness check.
    transport_was_up: bool,
    /// Host monotonic time of the tick being run, ns (see [`Cluster::tick_at`]): the clock
    /// liveness counts silence on, and the time a frame taken in is heard at.
    host_ns: u64,
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
    /// Set by [`Cluster::leave`]: every events frame from then on says so.
    leaving: bool,
    /// Neighbours that said they are leaving, heard last tick: taken as left this tick, so
    /// that their last replication frame, on another channel, is reconciled first.
    leaving_heard: Vec<ClusterId>,
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
            .map(|&n| (n, Peer::new()))
            .collect();
        let config_authority = config.authority;
        tracing::debug!(
            cluster = %config.cluster_id,
            neighbours = config.neighbours.len(),
            transport = %seam_transport::redact_url(&config.transport),
            "cluster open"
        );
        Ok(Self {
            replication_channel: channels::replication(config.cluster_id),
            encoder: ReplicationEncoder::default(),
            keyframes: Keyframes::new(config.keyframe_ticks, config.replication_interval),
            keys: IdMap::default(),
            scratch_owned: Vec::new(),
            scratch_states: Vec::new(),
            interest: Interest::new(config.region, config.spread),
            config,
            sim,
            transport,
            inbox: Inbox::default(),
            outgoing_ops: IdMap::default(),
            outgoing_acks: IdMap::default(),
            next_op_seq: first_op_seq(),
            outstanding: Outstanding::default(),
            outstanding_contacts: Outstanding::default(),
            settled: Settled::default(),
            op_timings: Vec::new(),
            handoff_log: Vec::new(),
            ledger: None,
            outgoing_contacts: IdMap::default(),
            transfers: IdMap::default(),
            handed: IdMap::default(),
            released: IdMap::default(),
            early_handoffs: IdMap::default(),
            custom_proxy: None,
            stats: ClusterStats::default(),
            liveness,
            last_states: IdMap::default(),
            adopted: IdMap::default(),
            transport_was_up: true,
            host_ns: monotonic_ns(),
            free_running: false,
            contact_merge: ContactMerge::default(),
            outgoing_impulses: IdMap::default(),
            settlement: Settlement::default(),
            predictions: Predictions::default(),
            leaving: false,
            leaving_heard: Vec::new(),
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

    /// Routed writes this cluster has sent (issued here, or taken on to forward) and not yet
    /// had answered; they are sent again until answered or too old (see
    /// `ClusterConfig::op_retry_ticks`).
    pub fn ops_unanswered(&self) -> usize {
        self.outstanding.len()
    }

    /// Contact reports this cluster has sent and not yet had answered; sent again like ops.
    pub fn contacts_unanswered(&self) -> usize {
        self.outstanding_contacts.len()
    }

    /// The hand-offs this cluster took and gave since the last call, in order (at most
    /// [`MAX_OP_TIMINGS`] kept between calls; more are counted in
    /// [`ClusterStats::handoff_log_dropped`]). A hand-off taken and given back within one
    /// tick shows here though the entity's owner after the tick is unchanged.
    pub fn take_handoffs(&mut self) -> Vec<HandoffEvent> {
        std::mem::take(&mut self.handoff_log)
    }

    /// Notes a hand-off for [`Cluster::take_handoffs`].
    fn log_handoff(&mut self, entity: EntityId, taken: bool) {
        if self.handoff_log.len() < MAX_OP_TIMINGS {
            self.handoff_log.push(HandoffEvent { entity, taken });
        } else {
            self.stats.handoff_log_dropped += 1;
        }
    }

    /// Keeps a ledger from now on: what became of each routed op and contact report here, by
    /// name (see `crate::ledger`), for [`Cluster::take_ledger`].
    pub fn keep_ledger(&mut self) {
        self.ledger.get_or_insert_with(Vec::new);
    }

    /// Takes the ledger entries since the last call (at most [`MAX_OP_TIMINGS`] kept between
    /// calls; more are counted in [`ClusterStats::ledger_dropped`]); empty unless
    /// [`Cluster::keep_ledger`] was called.
    pub fn take_ledger(&mut self) -> Vec<LedgerEntry> {
        self.ledger.as_mut().map(std::mem::take).unwrap_or_default()
    }

    /// The ops and contact reports sent from here and not answered yet, as ledger entries
    /// [`LedgerEvent::Unanswered`] at this tick: what a stopping cluster leaves unanswered.
    pub fn unanswered_names(&self) -> Vec<LedgerEntry> {
        let tick = self.sim.tick();
        let entry = |carried| {
            move |(issuer, seq)| LedgerEntry {
                tick,
                issuer,
                seq,
                carried,
                event: LedgerEvent::Unanswered,
                adopted_from: None,
            }
        };
        self.outstanding
            .names()
            .map(entry(Carried::Op))
            .chain(
                self.outstanding_contacts
                    .names()
                    .map(entry(Carried::Contact)),
            )
            .collect()
    }

    /// Notes in the ledger, if one is kept, what became of a name here.
    fn note(
        &mut self,
        key: OpKey,
        carried: Carried,
        event: LedgerEvent,
        adopted_from: Option<ClusterId>,
    ) {
        let Some(ledger) = &mut self.ledger else {
            return;
        };
        if ledger.len() < MAX_OP_TIMINGS {
            ledger.push(LedgerEntry {
                tick: self.sim.tick(),
                issuer: key.0,
                seq: key.1,
                carried,
                event,
                adopted_from,
            });
        } else {
            self.stats.ledger_dropped += 1;
        }
    }

    /// Notes an op's event in the ledger.
    fn note_op(&mut self, key: OpKey, event: LedgerEvent) {
        self.note(key, Carried::Op, event, None);
    }

    /// Notes in the ledger an op applied (or dropped) here on `target`, a body this cluster
    /// owns, and where the target was adopted from if this cluster holds it as an adopter.
    fn note_on_body(&mut self, key: OpKey, event: LedgerEvent, target: EntityId) {
        if self.ledger.is_none() {
            // No ledger: not even the lookup on the apply path.
            return;
        }
        let from = self.adopted.get(&target).copied();
        self.note(key, Carried::Op, event, from);
    }

    /// Notes a contact report's event in the ledger.
    fn note_contact(&mut self, key: OpKey, event: LedgerEvent) {
        self.note(key, Carried::Contact, event, None);
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

    /// Says to every neighbour that this cluster stops on purpose: one last physics-events
    /// frame each, marked `leaving`, so that they do not take it for dead when it falls silent
    /// and adopt nothing from it — what it owns leaves with it (hand it over first to keep it
    /// in the world); hand-offs to it that it has not taken go back to their senders. Call it
    /// once, after the last tick; a later tick says so again.
    pub fn leave(&mut self) -> Result<(), ClusterError> {
        self.leaving = true;
        for i in 0..self.config.neighbours.len() {
            let neighbour = self.config.neighbours[i];
            let frame = PhysicsEventsFrame {
                from: self.config.cluster_id,
                // One past the last tick's frame, which it would otherwise replay.
                tick: self.sim.tick() + 1,
                published_ns: monotonic_ns(),
                ops: Vec::new(),
                acks: Vec::new(),
                contacts: Vec::new(),
                impulses: Vec::new(),
                leaving: true,
            };
            self.stats.events_bytes += publish::publish_frame(
                self.transport.as_mut(),
                &channels::physics_events(neighbour),
                &frame,
            )? as u64;
        }
        Ok(())
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
            .filter(|(_, info)| info.owner == me)
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
        if info.owner != self.id() {
            return Err(refuse("not owned by this cluster"));
        }
        if to == self.id() {
            return Err(refuse("already owned here"));
        }
        if !self.config.neighbours.contains(&to) {
            return Err(refuse("not a neighbour"));
        }
        match self.neighbour_status(to) {
            Some(NeighbourStatus::Dead) => {
                return Err(refuse("the neighbour is taken for dead (silent)"));
            }
            Some(NeighbourStatus::Left) => return Err(refuse("the neighbour has left")),
            _ => {}
        }
        self.transfers.insert(entity, to);
        Ok(())
    }

    /// One tick using whatever has arrived (free-running pods). A neighbour silent for more
    /// than `neighbour_timeout_ticks` is taken for dead first (see [`NeighbourStatus`]).
    /// The same as [`Cluster::tick_at`] at the host's monotonic time now.
    pub fn tick(
        &mut self,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        self.tick_at(monotonic_ns(), user)
    }

    /// [`Cluster::tick`] with the host time given, in [`monotonic_ns`] nanoseconds: a
    /// neighbour is taken for dead only once it has been silent for `neighbour_timeout_ticks`
    /// ticks *and* that many `dt` of this clock, so a pod catching up after a stall (ticks back
    /// to back) does not take its neighbours for dead. Frames taken in since the last tick
    /// count as heard at `now_ns`. Tests drive this clock by hand instead of sleeping.
    pub fn tick_at(
        &mut self,
        now_ns: u64,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        self.free_running = true;
        self.host_ns = now_ns;
        self.drain()?;
        self.check_liveness();
        let frames = self.inbox.take_all();
        self.run_tick(frames, user)
    }

    /// What this cluster knows of `neighbour`'s liveness (`None` for a non-neighbour).
    pub fn neighbour_status(&self, neighbour: ClusterId) -> Option<NeighbourStatus> {
        self.liveness.get(&neighbour).map(|peer| peer.status)
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
        self.host_ns = monotonic_ns();
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
                    self.take_in(frame, received_ns);
                }
                self.drain()?;
            }
        }
        let frames = self.inbox.take_tick(tick, &self.config.neighbours);
        self.run_tick(frames, user)
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
        self.take_in(frame, received_ns);
        self.drain()?;
        Ok(true)
    }

    /// One tick on the frames the caller gathered: every phase, in order (see the crate docs).
    fn run_tick(
        &mut self,
        frames: TickFrames,
        user: impl FnOnce(&TickContext<'_>, &mut PhysicsHandle<'_>),
    ) -> Result<(), ClusterError> {
        // Reconcile the world with what the neighbours replicated: first the hand-offs held for
        // this tick, then the frames.
        self.interest.expire(self.sim.tick());
        self.take_early_handoffs();
        let keep_last = !self.config.world.is_empty();
        for frame in frames.replication {
            self.reconcile(&frame);
            if keep_last {
                let mut frame = frame;
                if !frame.is_whole()
                    && let Some(older) = self.last_states.get(&frame.from)
                {
                    // A delta frame without its keyframe: the rest of the picture is the one
                    // held before.
                    frame.fill_from(older);
                }
                self.last_states.insert(frame.from, frame);
            }
        }
        for neighbour in std::mem::take(&mut self.leaving_heard) {
            self.neighbour_left(neighbour);
        }
        self.leaving_heard.extend(
            frames
                .events
                .iter()
                .filter(|(frame, _)| frame.leaving)
                .map(|(frame, _)| frame.from),
        );
        self.surface_contacts(&frames.events);

        // User code; writes on remote-owned entities go to the outbox.
        let mut outbox = Outbox {
            neighbours: &self.config.neighbours,
            ops: &mut self.outgoing_ops,
            next_seq: &mut self.next_op_seq,
            tick: self.sim.tick(),
        };
        self.sim.run_user(&mut outbox, user);
        let tick = self.sim.tick();
        if self.config.coupling {
            self.predictions
                .routed(self.outgoing_ops.values().flatten(), tick);
        }

        // Contacts across the seam settled (see `crate::settle`), then routed writes received,
        // all applied just before the step; answers to this cluster's ops taken in, and those
        // due sent again (or applied, if their entity is this cluster's now).
        self.settle_seam_impulses(&frames.events, tick);
        self.take_acks(&frames.events, tick);
        self.apply_routed_ops(&frames.events, tick);
        self.resend_due(tick);
        self.resend_due_contacts(tick);

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
}

/// The number a cluster's first op gets: microseconds of the wall clock at its start, so a pod
/// restarted under the same id numbers its ops past those of its earlier life (owners would
/// otherwise take its new ops for repeats of old ones).
fn first_op_seq() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(1, |d| d.as_micros() as u64)
}

/// Whether every component of `v` is within `limit` in magnitude (NaN is not).
fn within(v: [f32; 3], limit: f32) -> bool {
    v.iter().all(|c| c.abs() <= limit)
}
