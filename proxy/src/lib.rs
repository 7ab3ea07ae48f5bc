//! seam-proxy — the three layers that make physics work across the seam between clusters:
//! proxies, routing and authority transfer, joining a `seam-sim` world to any
//! `seam-transport` backend.
//!
//! ```
//! use std::time::Duration;
//! use seam_proxy::prelude::*;
//!
//! // Two clusters in one process on iceoryx2's in-process transport. Ids from names: every
//! // process of one run (here "doc-<pid>") derives the same ones.
//! let run = format!("doc-{}", std::process::id());
//! let (a, b) = (ClusterId::named(&run, "a"), ClusterId::named(&run, "b"));
//! let url = format!("local?prefix={run}_");
//! let mut clusters = vec![
//!     Cluster::new(ClusterConfig::new(a, vec![b], &url))?,
//!     Cluster::new(ClusterConfig::new(b, vec![a], &url))?,
//! ];
//! let crate_ = EntityState::new(
//!     EntityId::named(&run, "crate"),
//!     a,
//!     BodySpec::new(Shape::cuboid(0.5, 0.5, 0.5)).density(500.0),
//! )
//! .at([10.0, 0.0, 0.0]);
//! clusters[0].spawn_owned(&crate_, BodyRole::Dynamic)?;
//! for _ in 0..2 {
//!     lockstep_round(&mut clusters, Duration::from_secs(5), |index, _context, physics| {
//!         if index == 1 {
//!             // B shoots: its raycast hits its proxy of A's crate, and the push it gives the
//!             // crate is routed to A, which applies it on its next tick.
//!             if let Some(hit) = physics.raycast([0.0; 3], [1.0, 0.0, 0.0], 50.0, None) {
//!                 physics.apply_impulse(hit.entity, [100.0, 0.0, 0.0]).expect("routed");
//!             }
//!         }
//!     })?;
//! }
//! # Ok::<(), seam_proxy::ClusterError>(())
//! ```
//!
//! # Architecture
//!
//! A [`Cluster`] owns a `ClusterSim` (its Rapier world) and a `Box<dyn Transport>`; nothing of a
//! backend shows in its API. It publishes on `replication:<its id>` and
//! `physics_events:<neighbour id>`, and listens on its neighbours' replication channels and its
//! own `physics_events` channel. One tick, in order:
//!
//! 1. **Drain** the inbox: neighbours' replication frames and this cluster's physics events.
//! 2. **Reconcile** the world with the replication frames (below).
//! 3. **User code** runs with the tick context and the physics handle. Reads and queries use the
//!    local world, proxies included; a write on an entity another cluster owns is queued for
//!    that owner.
//! 4. **Exchange**: one physics-events frame per neighbour before the step, with the ops
//!    queued for it and the impulses game code gave this cluster's own bodies; the
//!    neighbours' are waited for (`ClusterConfig::exchange`).
//! 5. **Routed ops** received are applied — the neighbours' of this very tick among them —,
//!    then the world **steps**.
//! 6. **Publish**: one replication frame with the states of the entities this cluster owns
//!    (every `replication_interval` ticks), and one physics-events frame per neighbour with
//!    answers, ops that missed the exchange and the contacts between this cluster's bodies
//!    and its proxies.
//!
//! Every frame is tagged with its sender's step count. [`Cluster::tick`] uses whatever has
//! arrived (free-running pods, which sleep in [`Cluster::wait`] between ticks): every events
//! frame, and of each neighbour's replication frames the newest, with any hand-off an older one
//! carried (the old owner stops listing an entity once handed, so dropping that frame would
//! lose the entity) — having waited, at most `neighbour_wait_ticks`, for the frames of
//! neighbours ticking in step with it; [`Cluster::tick_lockstep`] and [`lockstep_round`] wait,
//! by counting frames, for exactly the neighbours' frames of the same step count and keep
//! newer ones for later, so a run gives the same result on every transport. One thread
//! stepping several clusters in lock-step runs each tick in two halves
//! ([`Cluster::begin_lockstep`] for all, then [`Cluster::finish_lockstep`]), so that each has
//! its neighbours' exchanged ops before it steps.
//!
//! # Proxy lifecycle
//!
//! A neighbour entity is modelled only while its **extent** — the box its shape covers at its
//! replicated pose, grown by the way it sweeps before the next frame can replace that pose —
//! overlaps this cluster's `region` grown by `spread`, or the room (extent and sweep, grown by
//! `spread`) around one of this cluster's own bodies that has left that region: a floor whose
//! centre is far away still reaches the seam, a fast shot is modelled before it arrives, and a
//! body pushed over the seam meets what is there (see `replication`). Game code can widen it for
//! a while with [`Cluster::watch`] — the reach of an explosion or a long raycast about to run:
//! queries see only what the cluster models. A neighbour entity is spawned as a proxy the
//! first time its owner lists it there, updated from each replication frame — `Fixed`: set to
//! the pose; `KinematicVelocityBased`: given the velocities that carry it, position and
//! orientation alike, to where the entity will be at the next update (so it moves between
//! updates; see `replication`); `Custom`: a [`CustomProxy`] — and despawned when it is of
//! no more interest or its owner stops listing it. Every received state is checked first
//! (finite, within `max_magnitude`, a unit rotation, a shape with a size) whether or not it
//! will be modelled. Reads of a proxy's velocity give what its owner replicated.
//!
//! **Contacts push across the seam** (`ClusterConfig::coupling`, on by default): before each
//! step, a proxy of a simulated entity that a body of this cluster may touch becomes, for as
//! long as it may, a dynamic body of the entity's own mass moving with the replicated velocity
//! (see `seam_sim::coupling`). The owner's world does the same with its proxy of this cluster's
//! body, so each world solves the contact from the same bodies and keeps its own body's share:
//! a light ball bounces off a heavy crate and the crate takes its momentum, in the step they
//! meet, with nothing routed. Contacts between a body of this cluster and a proxy are also
//! sent to the proxy's owner, with their impulse and normal, delivered as routed ops are (kept
//! until answered, sent again, surfaced once per number); each cluster surfaces a contact
//! once, whether it saw it itself or first heard of it (see `contacts`).
//!
//! **Scenery** — terrain, floors, walls — is loaded by every cluster itself
//! ([`Cluster::spawn_scenery`]): a Fixed body owned by no cluster (`ClusterId::SCENERY`),
//! never replicated, handed over or adopted; writes on it are refused and contacts with it
//! reported to nobody.
//!
//! # Routing
//!
//! A write on a remote-owned entity goes, in this tick's exchange, to the owner this cluster
//! knows, which applies it just before its step of the same tick — as one world would (an
//! op that misses the exchange is applied at the owner's next step, the motion a body in free
//! flight missed added back). Writes are validated before they are queued (NaN, infinity and
//! unknown entities are refused at the caller).
//!
//! **Delivery: at least once, applied once** (see `delivery`). Each op is named by its issuer
//! and a number from the issuer's counter (started at the wall clock's microseconds, so a
//! restarted pod does not reuse numbers). Every receiver answers every op in its next events
//! frame to the sender ([`seam_sim::wire::OpAck`]): *done* — applied, dropped for good, or
//! taken on to forward — or *not here*. The sender keeps each op until it is answered done,
//! and sends it again every `op_retry_ticks` (and at once after *not here*) to the cluster it
//! then knows to own the target: the new owner after a hand-off, the adopter after the owner
//! was taken for dead — or applies it itself, if the entity is now its own. An owner
//! remembers the numbers it has closed per issuer (the last 16 384) and never
//! applies one twice: a repeat is answered and counted ([`ClusterStats::ops_repeated`]); a
//! number older than the window is dropped, counted. An op older than `max_op_age_ticks` (its
//! age counted on each holder's own clock) is dropped by the owner
//! ([`ClusterStats::ops_dropped_stale`]) and answered; a sender that hears nothing for twice
//! `neighbour_timeout_ticks` more gives it up ([`ClusterStats::ops_expired`]). An op reaching a
//! cluster which no longer owns its target is taken on and forwarded, once, to the owner that
//! cluster knows ([`ClusterStats::ops_forwarded`]), which then answers the forwarder; a
//! forwarded op that misses again is answered *not here* to the forwarder, which sends it on
//! where it knows the entity to be, or applies it itself if the entity is its own again
//! (taking it on closed its name there, which does not count as applying it). An op whose
//! entity neither the sender nor the receiver knows is dropped ([`ClusterStats::ops_dropped_gone`]). Memory is bounded: at most
//! `MAX_UNANSWERED` (4 096) unanswered ops per destination (more are dropped, counted) and
//! `MAX_ISSUERS` (256) windows of 2 KiB. Lost for good only: ops held by a sender that dies
//! (its unanswered ops die with it, like anything it never published), and an op applied by
//! an owner that dies before its answer goes out may be applied again by the adopter (if the
//! adopted state already holds its effect). A joint between entities of different owners is refused
//! (`create_joint` returns `None`). An impulse routed while the writer's proxy of its target is
//! coupled is also added to that proxy, from the step it is written until the owner's next
//! state of the entity: a blast on bodies of both sides pushes them apart together in the
//! writer's world instead of ramming its own bodies into proxies still standing (see
//! `contacts`).
//!
//! # Authority
//!
//! Ownership is the `cluster_id` in an entity's replicated state, and only the current owner's
//! frames can change it. [`Cluster::transfer_authority`] makes the owner's next replication frame
//! carry the entity's final pose and velocity with the new owner's id; the old owner turns its
//! body into a proxy right after publishing; the new owner, reading that frame, turns its proxy
//! into the dynamic body in place with that pose and velocity (or spawns it, if it had no proxy);
//! third clusters route writes to the new owner from then on. A hand-off goes only to a
//! neighbour heard from and not gone that models the entity (its extent reaches the
//! neighbour's region and spread on the world map), so there is a proxy to take over; the
//! rest is refused with the reason. In lock-step the old owner's last
//! dynamic step and the new owner's first are consecutive: at every step exactly one cluster
//! simulates the entity.
//!
//! Who hands what over is decided by game code ([`Cluster::transfer_authority`]) and by the
//! cluster's [`AuthorityPolicy`], asked at every replication frame (`ClusterConfig::authority`;
//! [`Cluster::set_authority_policy`] plugs in an affinity system). The default, [`Group`],
//! makes authority follow entities through the world as [`Spatial`] does — a dynamic body
//! whose centre, where it will be by the next frame, is more than a margin (0.25 m) past the
//! seam, inside a live neighbour's region, is handed to that neighbour — and gives bodies in
//! sustained contact where three or more clusters' bodies meet (a stack on a corner point) one
//! owner, handed as a group. Fast bodies are handed over before the step that crosses, so the
//! cluster they enter simulates them against its own bodies; the chain keeps up while a body
//! moves less than a region's width between frames (see `authority`).
//!
//! # Untrusted input
//!
//! Every received frame is counted once in [`ClusterStats`]: taken (`frames_accepted`), or
//! refused as undecodable, of another format version, from a sender that is not a neighbour or
//! not the cluster its channel names, as a replay (a frame of a live sender tagged no later than
//! one of its frames of the same kind already taken: a sender publishes one per tick, in order;
//! the first is kept), as tagged further ahead than the sender could be (below), or as from a
//! pod its cluster has replaced since (its incarnation, `frames_stale`). States from
//! a cluster that does not own their entity, with NaN, a coordinate or velocity beyond
//! `max_magnitude`, a rotation that is not one or a shape with no size are rejected and
//! counted; so are routed ops with NaN, beyond `max_magnitude`, too old, or repeated (an op
//! for an entity not owned here is answered "not here"). None of it panics or touches the
//! world.
//!
//! # Liveness
//!
//! A free-running cluster that has heard from a neighbour and then hears nothing for more than
//! `neighbour_timeout_ticks` of its own ticks, and as long in host time (ticks × `dt`: a pod
//! catching up after a stall runs ticks back to back), takes it for dead
//! ([`NeighbourStatus::Dead`]) and counts it in [`ClusterStats::neighbours_lost`]. While the
//! cluster's own transport is down (`Transport::is_connected`, a Redis outage) nobody is taken
//! for dead, and every neighbour's clock restarts when it comes back. A frame from a silent
//! neighbour makes it alive again (`neighbours_rejoined`). A hand-off to a neighbour taken for
//! dead is refused; writes for it wait, unsent, to go to the adopter of their entity (or
//! expire, see Routing). A
//! frame tagged further ahead than a live neighbour could be (pods share one schedule: beyond
//! this cluster's own tick, or its last frame plus one tick per `dt` since, by more than twice
//! the timeout) is dropped (`frames_implausible`): it could only be forged, and would otherwise
//! pass for the newest. Every frame carries its pod's incarnation ([`Cluster::incarnation`]):
//! frames of a pod older than one heard since of the same cluster are refused
//! (`frames_stale`, logged naming the sender), and a newer pod's ticks count afresh.
//!
//! A cluster that stops on purpose calls [`Cluster::leave`]: a last events frame to each
//! neighbour, marked `leaving`. They take it as [`NeighbourStatus::Left`] (one tick later, so
//! its last replication frame is reconciled first): never taken for dead, nothing adopted from
//! it — what it owns leaves with it — and hand-offs to it that it had not taken come back
//! (`handoffs_taken_back`). `seam node` leaves after its last tick, so a pod still ticking
//! behind the schedule does not adopt what its finished neighbours end the run owning.
//!
//! # Adoption: no entity lost
//!
//! With a world map ([`ClusterConfig::world`]: every cluster's region and neighbours), the
//! entities of a neighbour taken for dead are adopted from its last replication frame, which
//! every neighbour receives in full and keeps:
//!
//! > The adopter of an entity of dead cluster `D` is, among `D`'s neighbours not taken for dead,
//! > the one whose region is nearest to the entity's last replicated position; a tie goes to the
//! > smallest cluster id.
//!
//! The rule goes by the entity's position (its centre), not its extent: an owner must be one
//! cluster, and every survivor must name the same one, while an extent can reach into several
//! regions (the `Spatial` policy decides ownership by the centre for the same reason).
//!
//! Every survivor computes the same rule, so exactly one adopts each entity (a proxy becomes
//! the body in place, or the body is spawned) and the others despawn their proxies of `D`
//! until the adopter's frames bring them back. An entity this cluster handed to `D` that `D`
//! never listed is taken back. Counted in `entities_adopted` and `handoffs_reclaimed`.
//!
//! When `D` is heard from again, each adopter hands the entities it adopted from `D` back by a
//! normal hand-off at its next replication frame (`entities_returned`): a pod restarted after a
//! crash starts empty and gets its entities back; one that was only stalled and still simulates
//! them keeps its own copy (a hand-off of an entity it owns changes nothing there), and the
//! adopter's copy stops.
//!
//! Limits: what happened to `D`'s entities after its last frame reached the survivors (the
//! motion since, writes routed to it, projectiles it fired and never published) is lost, and
//! that is the only loss; the adopted state is up to `neighbour_timeout_ticks` old. The rule
//! needs the survivors to agree on `D`'s last frame (true unless `D` died while publishing it)
//! and on who is alive; a candidate that is not this cluster's neighbour is assumed alive. An
//! adopted entity handed on to a third cluster before `D` returns is not returned: if `D` was
//! only stalled and still claims it, two clusters simulate it. A replayed frame of a dead `D`
//! makes it look alive until it times out again (the entities go back and are adopted again
//! from that frame). Without a world map nothing is adopted
//! and `D`'s proxies are despawned.
//!
//! # Layout
//!
//! - [`prelude`] — what game code imports.
//! - `cluster` — [`Cluster`]: the pipeline; `run_until_exchange` and `finish_tick` list the
//!   phases a tick runs (the exchange of routed ops between them), each a call on a part that
//!   owns its state:
//!   - `inbox` — frames in, by sender and tick (for lock-step);
//!   - `neighbours` — who is alive ([`NeighbourStatus`]), and custody of the dead's entities;
//!   - `replication` — frames out ([`extent`]-based interest, keyframes) and the world
//!     reconciled with the neighbours' (proxies, [`CustomProxy`]);
//!   - `handoff` — hand-offs queued, in transit, released, held early, taken back;
//!   - `routing` — writes on remote-owned entities, applied once by their owner;
//!   - `contacts` — contact reports, seam impulses settled, pushes predicted;
//!   - `delivery` — at least once, applied once, for ops and contact reports alike.
//! - `events` — [`ClusterEvent`], the one stream every part emits on, and its consumers:
//!   [`ClusterStats`], [`LedgerEntry`]; [`OpTiming`].
//! - `authority` — who should own an entity: [`AuthorityPolicy`], the built-in [`Group`] and
//!   [`Spatial`] policies, [`AuthorityMode`]; who adopts a dead neighbour's entities.
//! - `config` — [`ClusterConfig`], [`ProxyMode`].
//! - `checks` — the rules a configuration must meet ([`ClusterConfig::check`],
//!   [`ConfigError`]).
//! - `world` — [`Region`], [`WorldCluster`] and [`world_map`].
//! - `runtime` — [`Schedule`] (a free-running cluster's ticks on the host's clock, as a pod
//!   runs them) and [`lockstep_round`] (N clusters of one process, tick by tick).
//! - `bridge` — [`Bridge`]: one host's channels passed to and from a Redis server.
//! - `clock` — the host monotonic clock ([`monotonic_ns`]).
//! - `channels` — channel names ([`replication`], [`physics_events`]), and the name a cluster
//!   claims so that it runs once.
//! - `error` — [`ClusterError`].
//! - `acl` — [`redis_acl_rules`]: the Redis ACL user of one cluster's pod.

mod acl;
mod authority;
mod bridge;
mod channels;
mod checks;
mod clock;
mod cluster;
mod config;
mod contacts;
mod delivery;
mod error;
mod events;
mod handoff;
mod inbox;
mod neighbours;
mod replication;
mod routing;
mod runtime;
mod world;

pub use acl::redis_acl_rules;
pub use authority::{
    AuthorityMode, AuthorityPolicy, AuthorityView, Group, GroupSettings, NeighbourView, Spatial,
    SpatialSettings, Touching,
};
pub use bridge::{Bridge, BridgeRoutes, DirectionCounters, DirectionStats};
pub use channels::{physics_events, replication};
pub use checks::{ConfigError, name_ok};
pub use clock::{monotonic_ns, thread_cpu_ns};
pub use cluster::{Cluster, DRAIN_S, Phase, PhaseCpu};
pub use config::{ClusterConfig, DEFAULT_KEYFRAME_TICKS, ProxyMode};
pub use contacts::{HALF_WAITS_TICKS, MERGE_WINDOW_TICKS};
pub use error::ClusterError;
pub use events::{
    Carried, ClusterEvent, ClusterStats, ContactGiveUp, FrameRefusal, LedgerEntry, LedgerEvent,
    MAX_EVENTS, Name, OpDrop, OpTiming, TickEvent, parse_cluster,
};
pub use neighbours::NeighbourStatus;
pub use replication::{CustomProxy, extent};
pub use runtime::{DRAIN_TICKS_UNSCHEDULED, Due, Schedule, lockstep_round};
pub use world::{Region, WorldCluster, world_map};

/// What game code needs to run clusters, in one import: `use seam_proxy::prelude::*;`.
pub mod prelude {
    pub use crate::{
        AuthorityMode, AuthorityPolicy, Cluster, ClusterConfig, ClusterError, NeighbourStatus,
        ProxyMode, Region, Schedule, WorldCluster, lockstep_round, monotonic_ns, world_map,
    };
    pub use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, PhysicsOp, Shape};
    pub use seam_sim::{BodyRole, PhysicsHandle, TickContext};
}
