//! [`Cluster`]: one cluster's world joined to a transport — a thin pipeline over the parts that
//! own its state, asked once per tick in a fixed order (`tick`).
//!
//! # Layout
//!
//! - here: [`Cluster`], its parts, and what game code calls between ticks.
//! - `bodies` — what game code adds to the world and changes in it: owned bodies, scenery,
//!   catalog shapes, roles, owners (`transfer_authority`), names.
//! - `tick` — the ways to run a tick (free-running, lock-step in one call or two halves) and
//!   `run_until_exchange` and `finish_tick`, the list of phases.
//! - `start` — the first step: the world as it starts sent, the neighbours' taken in before it.
//! - `exchange` — the exchange before the step: this tick's ops and own writes out, the
//!   neighbours' waited for and applied.
//! - `receive` — frames taken off the transport into the inbox (and `wait` between ticks).
//! - `catch_up` — how far ahead a hand-off or claim is held while catching up after a stall.
//! - `coupling` — proxies a body here may touch made dynamic for the step.
//! - `publish` — this tick's frames out: replication (with the policy's hand-offs) and one
//!   physics-events frame per neighbour.
//! - `phases` — the thread CPU time of each phase, when measured.
//! - `warnings` — what is logged of what is counted: refused frames and dropped ops.

use seam_sim::wire::{ClusterId, EntityId, PhysicsEventsFrame, Stage};
use seam_sim::{ClusterSim, SimConfig};
use seam_transport::Transport;

use crate::authority::{AuthorityMode, AuthorityPolicy, Group, Spatial};
use crate::channels;
use crate::clock::monotonic_ns;
use crate::config::ClusterConfig;
use crate::contacts::{Predictions, Reports, SeamImpulses};
use crate::delivery::{Numbers, Receipts, Retry};
use crate::error::ClusterError;
use crate::events::{Carried, ClusterStats, Events, LedgerEntry, LedgerEvent, Name, TickEvent};
use crate::handoff::Handoffs;
use crate::inbox::Inbox;
use crate::neighbours::{Custody, NeighbourStatus, Neighbours};
use crate::replication::{CustomProxy, Interest, Keys, Proxies, Publisher};
use crate::routing::Routing;
use crate::world::Region;

mod bodies;
mod catch_up;
mod coupling;
mod exchange;
mod phases;
mod publish;
mod receive;
mod start;
mod tick;
mod warnings;

pub use phases::{Phase, PhaseCpu};

/// How long before its last tick a pod stops the policy's hand-offs (see
/// [`Cluster::stop_policy_handoffs`]), seconds: pods on one schedule are a few ticks apart,
/// and a pod that fell behind catches up within a fraction of this.
pub const DRAIN_S: f64 = 0.5;

/// Room for a physics-events frame when advertising (about 80 ops; larger frames grow it).
const EVENTS_ROOM: usize = 4096;

/// One simulation cluster: its world, its transport, and the parts that make physics work
/// across the seam, each owning its state (see the crate docs for what each does).
pub struct Cluster {
    config: ClusterConfig,
    sim: ClusterSim,
    transport: Box<dyn Transport>,
    /// Everything that happens, counted and (on request) kept.
    events: Events,
    /// Frames received and not used yet.
    inbox: Inbox,
    /// Each neighbour's last keyframe.
    keys: Keys,
    /// Who is alive.
    neighbours: Neighbours,
    /// The dead's last pictures, and what was adopted from them.
    custody: Custody,
    /// Hand-offs queued, in transit, released and held.
    handoffs: Handoffs,
    /// This cluster's replication frames.
    publisher: Publisher,
    /// Where neighbour entities are modelled.
    interest: Interest,
    /// How proxies follow their entities.
    proxies: Proxies,
    /// The numbers of the ops and reports issued here.
    numbers: Numbers,
    /// The names closed here, and the answers owed.
    receipts: Receipts,
    /// Routed ops on their way.
    routing: Routing,
    /// Contact reports on their way, and contacts surfaced lately.
    reports: Reports,
    /// Impulses at the seam, exchanged and settled.
    seam: SeamImpulses,
    /// Impulses routed by game code, shown on this world's coupled proxies of their targets.
    predictions: Predictions,
    /// The policy asked for hand-offs at each replication frame.
    policy: Option<Box<dyn AuthorityPolicy>>,
    /// When unanswered ops and reports go again, and when they are given up.
    retry: Retry,
    /// Host monotonic time of the tick being run, ns (see [`Cluster::tick_at`]): the clock
    /// liveness counts silence on, and the time a frame taken in is heard at.
    host_ns: u64,
    /// How far ahead a neighbour's hand-off or claim is held, behind after a stall.
    catch_up: catch_up::CatchUp,
    /// The thread CPU time of each phase, when measured (see [`Cluster::time_phases`]).
    phases: phases::PhaseClock,
    /// Ticking free-running (`tick`, `wait`) rather than in lock-step: the inbox then keeps
    /// one replication frame per neighbour.
    free_running: bool,
    /// This pod's incarnation (see [`Cluster::incarnation`]).
    incarnation: u64,
    /// The routed ops dropped as of the last warning about them (see `warnings`).
    ops_dropped_logged: u64,
    /// Set by [`Cluster::leave`]: every events frame from then on says so.
    leaving: bool,
    /// A tick has run up to the exchange and not finished yet (see
    /// [`Cluster::begin_lockstep`]).
    begun: bool,
    /// Free-running, this tick started with every live neighbour in step and its frames of
    /// the step before in, as a lock-step tick does.
    in_step: bool,
}

impl Cluster {
    /// Notes the host time of the tick about to run (see [`Cluster::tick_at`]).
    fn note_host_time(&mut self, now_ns: u64) {
        self.catch_up.note(self.sim.tick(), now_ns, &self.config);
        self.host_ns = now_ns;
    }

    /// Opens the transport the configuration names and subscribes to the neighbours.
    ///
    /// A cluster runs once: it claims its id on the transport first (see
    /// [`Transport::claim`]), and a second pod of a cluster that runs already fails here with
    /// [`ClusterError::AlreadyRunning`] naming the running one (its process id, host and start
    /// time). On shared memory iceoryx2 admits one holder; on Redis a lease the running pod
    /// renews every tick, so a pod restarted after a crash waits for the crashed one's lease
    /// (3 s, `lease_ms` in the URL) to lapse before it starts. A pod whose lease lapsed while
    /// it was stopped and was taken over stops with the same error at its next tick.
    pub fn new(config: ClusterConfig) -> Result<Self, ClusterError> {
        config.check()?;
        let transport = seam_transport::open(&config.transport)?;
        Self::with_transport(config, transport)
    }

    /// A cluster on a transport opened by the caller.
    pub fn with_transport(
        config: ClusterConfig,
        mut transport: Box<dyn Transport>,
    ) -> Result<Self, ClusterError> {
        config.check()?;
        let already = |source| ClusterError::AlreadyRunning {
            cluster: config.cluster_id,
            source,
        };
        let incarnation = transport
            .claim(&channels::claim(config.cluster_id), &channels::claimant())
            .map_err(already)?;
        for &neighbour in &config.neighbours {
            transport.subscribe(&channels::replication(neighbour))?;
        }
        transport.subscribe(&channels::physics_events(config.cluster_id))?;
        let sim = ClusterSim::new(SimConfig {
            cluster_id: config.cluster_id,
            dt: config.dt,
            gravity: config.gravity,
            max_linear_velocity: config.max_linear_velocity,
            max_op_magnitude: config.max_magnitude,
        });
        tracing::debug!(
            cluster = %config.label(config.cluster_id),
            neighbours = config.neighbours.len(),
            transport = %seam_transport::redact_url(&config.transport),
            "cluster open"
        );
        Ok(Self {
            events: Events::default(),
            inbox: Inbox::default(),
            keys: Keys::default(),
            neighbours: Neighbours::new(&config),
            custody: Custody::default(),
            handoffs: Handoffs::default(),
            publisher: Publisher::new(&config, incarnation),
            incarnation,
            ops_dropped_logged: 0,
            interest: Interest::new(config.region, config.spread),
            proxies: Proxies::default(),
            numbers: Numbers::from_clock(),
            receipts: Receipts::default(),
            routing: Routing::default(),
            reports: Reports::default(),
            seam: SeamImpulses::default(),
            predictions: Predictions::default(),
            policy: match config.authority {
                AuthorityMode::Spatial(settings) => Some(Box::new(Spatial::new(settings))),
                AuthorityMode::Group(settings) => Some(Box::new(Group::new(settings))),
                AuthorityMode::Scripted | AuthorityMode::Custom => None,
            },
            retry: Retry::new(
                config.op_retry_ticks,
                config.max_op_age_ticks,
                config.neighbour_timeout_ticks,
            ),
            host_ns: monotonic_ns(),
            catch_up: catch_up::CatchUp::default(),
            phases: phases::PhaseClock::default(),
            free_running: false,
            leaving: false,
            begun: false,
            in_step: false,
            config,
            sim,
            transport,
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

    /// Whether this cluster owns `entity` at the end of its last tick: its body here is the
    /// entity's, or it handed the entity over in that tick's frame (it stepped the body as
    /// owner in that tick; the new owner counts it from the next, see
    /// `ClusterEvent::HandoffTaken`). Taken between ticks, over every pod of a world, each
    /// entity is owned by exactly one, hand-offs included.
    pub fn owns(&self, entity: EntityId) -> bool {
        let me = self.config.cluster_id;
        self.sim.info(entity).is_some_and(|info| info.owner == me)
            || (!self.begun && self.handoffs.given_last_tick().contains(&entity))
    }

    /// Every entity this cluster owns at the end of its last tick (see [`Cluster::owns`]).
    pub fn owned(&self) -> impl Iterator<Item = EntityId> + '_ {
        let me = self.config.cluster_id;
        let handed: &[EntityId] = if self.begun {
            &[]
        } else {
            self.handoffs.given_last_tick()
        };
        self.sim
            .entities()
            .filter(move |(_, info)| info.owner == me)
            .map(|(id, _)| id)
            .chain(handed.iter().copied())
    }

    /// What the cluster has counted: every event of its stream (see `crate::events`).
    pub fn stats(&self) -> ClusterStats {
        self.events.stats()
    }

    /// What the transport has counted.
    pub fn transport_stats(&self) -> seam_transport::Stats {
        self.transport.stats()
    }

    /// Keeps every event from now on, stamped with its tick, for [`Cluster::take_events`]:
    /// routed ops with their stage times, hand-offs, what became of each op and contact
    /// report by name (the ledger, see [`LedgerEntry::from_event`]).
    pub fn keep_events(&mut self) {
        self.events.keep();
    }

    /// Takes the events kept since the last call (at most [`MAX_EVENTS`](crate::MAX_EVENTS)
    /// between calls; more are counted in [`ClusterStats::events_dropped`]); empty unless
    /// [`Cluster::keep_events`] was called.
    pub fn take_events(&mut self) -> Vec<TickEvent> {
        self.events.take()
    }

    /// Routed writes this cluster has sent (issued here, or taken on to forward) and not yet
    /// had answered; they are sent again until answered or too old (see
    /// `ClusterConfig::op_retry_ticks`).
    pub fn ops_unanswered(&self) -> usize {
        self.routing.unanswered()
    }

    /// Contact reports this cluster has sent and not yet had answered; sent again like ops.
    pub fn contacts_unanswered(&self) -> usize {
        self.reports.unanswered()
    }

    /// The ops and contact reports sent from here and not answered yet, as ledger entries
    /// [`LedgerEvent::Unanswered`] at this tick: what a stopping cluster leaves unanswered.
    pub fn unanswered_names(&self) -> Vec<LedgerEntry> {
        let tick = self.sim.tick();
        let entry = |carried| {
            move |name: Name| LedgerEntry {
                tick,
                issuer: name.issuer,
                seq: name.seq,
                carried,
                event: LedgerEvent::Unanswered,
                adopted_from: None,
            }
        };
        self.routing
            .names()
            .map(entry(Carried::Op))
            .chain(self.reports.names().map(entry(Carried::Contact)))
            .collect()
    }

    /// This pod's incarnation: when it claimed its cluster, by the transport's clock
    /// (microseconds since the UNIX epoch; see [`Transport::claim`]). Every frame it publishes
    /// carries it, and neighbours refuse frames of an older incarnation than the newest they
    /// have seen of this cluster, so a pod taken over that still publishes is not heard.
    pub fn incarnation(&self) -> u64 {
        self.incarnation
    }

    /// What this cluster knows of `neighbour`'s liveness (`None` for a non-neighbour).
    pub fn neighbour_status(&self, neighbour: ClusterId) -> Option<NeighbourStatus> {
        self.neighbours.status(neighbour)
    }

    /// Carries on the world's tick count from `tick`: a pod restarted into a running world
    /// resumes where the others are, so its frames' ticks stay in line with theirs. Call it
    /// before the first tick.
    pub fn resume_at(&mut self, tick: u64) {
        self.sim.resume_at(tick);
        self.events.at_tick(self.sim.tick());
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
            // One past the last tick's frame, which it would otherwise replay.
            let mut frame = PhysicsEventsFrame::empty(
                self.config.cluster_id,
                self.sim.tick() + 1,
                Stage::AfterStep,
                monotonic_ns(),
            );
            frame.leaving = true;
            frame.incarnation = self.incarnation;
            self.publish_events_frame(neighbour, &frame)?;
        }
        Ok(())
    }

    /// Sets the hook that moves proxies in [`ProxyMode::Custom`](crate::ProxyMode::Custom).
    pub fn set_custom_proxy(&mut self, proxy: Box<dyn CustomProxy>) {
        self.proxies.set_custom(proxy);
    }

    /// Keeps this cluster's claim on its id (see [`Cluster::new`]): an error once another pod
    /// took it over.
    fn keep_claim(&mut self) -> Result<(), ClusterError> {
        let cluster = self.config.cluster_id;
        self.transport
            .keep_claims()
            .map_err(|source| ClusterError::AlreadyRunning { cluster, source })
    }
}
