//! What a cluster is told at start: [`ClusterConfig`] and [`ProxyMode`].

use seam_sim::BodyRole;
use seam_sim::wire::{ClusterId, EntityId, Motion, StateEncoding};

use crate::authority::AuthorityMode;
use crate::world::{Region, WorldCluster};

/// How a cluster models neighbour entities.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ProxyMode {
    /// A Fixed body set to each replicated pose: exact at updates, still in between. A body
    /// its owner moves kinematically (a platform) is proxied as in `KinematicVelocityBased`
    /// even so (see [`ProxyMode::role_for`]).
    #[default]
    Fixed,
    /// A kinematic body given the velocity that reaches each replicated pose one tick later:
    /// moves between updates, so contacts and queries see it where it is heading.
    KinematicVelocityBased,
    /// A kinematic position-based body moved by a [`CustomProxy`](crate::CustomProxy).
    Custom,
}

impl ProxyMode {
    /// The role a proxy's body has in this mode (when it is not coupled for a step).
    pub fn role(self) -> BodyRole {
        match self {
            ProxyMode::Fixed => BodyRole::Fixed,
            ProxyMode::KinematicVelocityBased => BodyRole::KinematicVelocityBased,
            ProxyMode::Custom => BodyRole::KinematicPositionBased,
        }
    }

    /// The role of a proxy of an entity its owner moves as `motion`: a body its owner moves
    /// kinematically (a platform) is proxied kinematic with its velocity in every mode but
    /// `Custom` (where the hook decides), since Rapier carries what rests on a body only
    /// through that body's velocity, which a Fixed body does not have; every other entity
    /// by the mode.
    pub fn role_for(self, motion: Motion) -> BodyRole {
        match (self, motion) {
            (ProxyMode::Fixed, Motion::Kinematic) => BodyRole::KinematicVelocityBased,
            _ => self.role(),
        }
    }
}

/// A cluster's configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct ClusterConfig {
    /// This cluster.
    pub cluster_id: ClusterId,
    /// The clusters whose entities this one may see and write to.
    pub neighbours: Vec<ClusterId>,
    /// The part of the world this cluster observes.
    pub region: Region,
    /// How far beyond the region neighbour entities are still modelled, metres.
    pub spread: f32,
    /// How neighbour entities are modelled.
    pub proxy_mode: ProxyMode,
    /// Step length, seconds.
    pub dt: f32,
    /// A replication frame every this many ticks (1: every tick).
    pub replication_interval: u64,
    /// Largest linear speed a body may have, m/s (see `seam_sim::SimConfig`).
    pub max_linear_velocity: f32,
    /// Gravity, m/s².
    pub gravity: [f32; 3],
    /// Transport URL: `shm`, `local` or `redis://…`.
    pub transport: String,
    /// A neighbour heard from before and silent for more than this many ticks is taken for
    /// dead (and as long in host time, ticks × `dt`): its entities are adopted (see `world`)
    /// or its proxies despawned, and it is counted in `ClusterStats::neighbours_lost`
    /// (free-running ticks only; lock-step waits for it instead). 0 never gives up.
    pub neighbour_timeout_ticks: u64,
    /// A routed write unanswered this many ticks after it was sent is sent again, to the
    /// cluster this one then knows to own its target (see `crate::delivery`). Default 10
    /// (167 ms at 60 Hz): an answer comes back within 2–3 ticks on one host and about 5 over
    /// a 20 ms network, so a resend is almost always for a lost frame, and a repeat costs
    /// only bytes (the owner applies each op once).
    pub op_retry_ticks: u64,
    /// A routed write older than this many ticks is not applied: the owner drops it, counted
    /// in `ClusterStats::ops_dropped_stale`, and answers, so the sender forgets it (a sender
    /// that hears nothing for twice `neighbour_timeout_ticks` more gives it up, counted in
    /// `ops_expired`). Age is counted on each holder's own clock, so clusters need not share
    /// a tick count. Default 30 (0.5 s at 60 Hz): enough for two resends after lost frames
    /// and a slow network, while a push applied later lands on a body that has moved on
    /// (a metre at 2 m/s) in a scene that has moved on; writes caught by a neighbour's death
    /// (noticed after `neighbour_timeout_ticks`, 1 s) therefore expire rather than land a
    /// second late on the adopter.
    pub max_op_age_ticks: u64,
    /// Largest magnitude accepted from another cluster for any coordinate of a replicated
    /// position, any component of a replicated velocity, or any component of a routed op
    /// (metres, m/s, rad/s, N, N·s): beyond it the state or
    /// op is dropped and counted, so a peer cannot move a body a light-year away or give it an
    /// absurd impulse.
    pub max_magnitude: f32,
    /// Every cluster of the world, with its region and neighbours. With it, the survivors of a
    /// neighbour taken for dead agree, without talking, on which of them adopts each of its
    /// entities (see `crate::authority`), and the [`AuthorityMode::Spatial`] policy knows where
    /// its neighbours are. Empty: a dead neighbour's entities are not adopted, and `Spatial`
    /// hands nothing over.
    pub world: Vec<WorldCluster>,
    /// Which hand-offs the cluster makes besides those game code asks for (see
    /// `crate::authority`).
    pub authority: AuthorityMode,
    /// Contacts across the seam push both ways: a proxy of a simulated entity that a body
    /// simulated here may touch takes part in the step as a dynamic body of the entity's mass
    /// (see `seam_sim::coupling`). `false`: proxies stay immovable (Fixed) or infinitely heavy
    /// (kinematic) whatever they meet. [`ProxyMode::Custom`] proxies are never coupled.
    pub coupling: bool,
    /// How replication frames write motion: [`StateEncoding::Exact`] floats (the default), or
    /// [`StateEncoding::Quantized`] (fixed-point positions to ±0.49 mm, smallest-three
    /// rotations, half-float velocities; 55 bytes a state instead of 77). Receivers read
    /// either, so clusters of one world may differ.
    pub state_encoding: StateEncoding,
    /// A full replication frame (a keyframe) at most every this many ticks; the frames between
    /// list only the states that changed since the keyframe and mark the rest unchanged, a bit
    /// each (see `crate::replication`). Receivers see the same states either way; what it buys
    /// is bytes and encoding for bodies at rest. A lost keyframe leaves a receiver with what
    /// changed since and the rest of its picture (nothing despawned) until the next one, so
    /// this bounds how long a lost frame can leave a proxy wrong. 0 or 1: every frame is a
    /// keyframe.
    pub keyframe_ticks: u64,
    /// Routed ops act in the step they were written in: after game code, each cluster sends
    /// every neighbour an events frame before its step (the *exchange*) with the ops it
    /// wrote on that neighbour's entities and the impulses it gave its own bodies, and applies
    /// the neighbours' before stepping (see `crate::routing`). In lock-step it waits for every
    /// neighbour's; free-running, for each live neighbour ticking in step with it, at most
    /// `neighbour_wait_ticks`. Every cluster of a world must agree on it. `false`: ops go
    /// after the step and land a tick later, caught up only for bodies touching nothing.
    pub exchange: bool,
    /// Free-running with the exchange, how long a tick waits for a live neighbour ticking in
    /// step with this cluster, in ticks of `dt` (default 0.25: 4.2 ms at 60 Hz): at its start
    /// for the neighbour's frames of the step before, and before the step for its exchange
    /// frame. Pods ticking in phase (as `seam run` starts them) then see each other's steps as
    /// lock-step clusters do; a neighbour later than this is not waited for (counted in
    /// `ClusterStats::steps_missed` and `exchanges_missed`), and what it sends is used when it
    /// comes. 0: never wait.
    pub neighbour_wait_ticks: f32,
    /// Names of clusters (this one, its neighbours, any on the world map) for logs and
    /// reports; a cluster without one is shown by its id. `seam run` names the scene's.
    pub names: std::collections::BTreeMap<ClusterId, String>,
    /// Names of entities for logs and reports, as for clusters (`seam run` names the scene's:
    /// `name`, or `name#i` for the copies of a grid); more can be added as the game spawns
    /// them ([`Cluster::name_entity`](crate::Cluster::name_entity)).
    pub entity_names: std::collections::BTreeMap<EntityId, String>,
}

/// The default [`ClusterConfig::keyframe_ticks`]: half a second at 60 Hz.
pub const DEFAULT_KEYFRAME_TICKS: u64 = 30;

impl ClusterConfig {
    /// A cluster observing everything (`region` [`Region::EVERYWHERE`], so `spread` 0 m: set
    /// both, or give the region on the world map), with Fixed proxies, 60 Hz, replication
    /// every tick, neighbours taken for dead after 60 silent ticks, and the default authority
    /// policy (which, observing everything, hands nothing over until given a region and a
    /// world map).
    pub fn new(cluster_id: ClusterId, neighbours: Vec<ClusterId>, transport: &str) -> Self {
        let sim = seam_sim::SimConfig::new(cluster_id);
        Self {
            cluster_id,
            neighbours,
            region: Region::EVERYWHERE,
            spread: 0.0,
            proxy_mode: ProxyMode::Fixed,
            dt: sim.dt,
            replication_interval: 1,
            max_linear_velocity: sim.max_linear_velocity,
            gravity: sim.gravity,
            transport: transport.to_owned(),
            neighbour_timeout_ticks: 60,
            op_retry_ticks: 10,
            max_op_age_ticks: 30,
            max_magnitude: 1.0e6,
            world: Vec::new(),
            authority: AuthorityMode::default(),
            coupling: true,
            state_encoding: StateEncoding::Exact,
            keyframe_ticks: DEFAULT_KEYFRAME_TICKS,
            exchange: true,
            neighbour_wait_ticks: 0.25,
            names: std::collections::BTreeMap::new(),
            entity_names: std::collections::BTreeMap::new(),
        }
    }

    /// Cluster `cluster_id` of the world `clusters` (id, region and spread of each, as
    /// [`world_map`](crate::world_map) takes them): its region, spread and neighbours from its
    /// own entry and the whole world map, each given once; otherwise as [`ClusterConfig::new`].
    /// A `cluster_id` not among `clusters` is refused (field `world`).
    pub fn in_world(
        cluster_id: ClusterId,
        clusters: &[(ClusterId, Region, f32)],
        transport: &str,
    ) -> Result<Self, crate::ConfigError> {
        let world = crate::world_map(clusters);
        let (Some(&(_, region, spread)), Some(me)) = (
            clusters.iter().find(|(id, ..)| *id == cluster_id),
            world.iter().find(|entry| entry.id == cluster_id),
        ) else {
            return Err(crate::ConfigError {
                field: "world".into(),
                value: format!("{:?}", clusters.iter().map(|c| c.0).collect::<Vec<_>>()),
                rule: "the world map must list this cluster (cluster_id)",
            });
        };
        let mut config = Self::new(cluster_id, me.neighbours.clone(), transport);
        config.region = region;
        config.spread = spread;
        config.world = world;
        Ok(config)
    }

    /// How logs and reports name cluster `id`: `name (id)` where `names` has it, else the id.
    pub fn label(&self, id: ClusterId) -> String {
        match self.names.get(&id) {
            Some(name) => format!("{name} ({id})"),
            None => id.to_string(),
        }
    }

    /// How logs and reports name entity `id`: `name (id)` where `entity_names` has it, else
    /// the id.
    pub fn entity_label(&self, id: EntityId) -> String {
        match self.entity_names.get(&id) {
            Some(name) => format!("{name} ({id})"),
            None => id.to_string(),
        }
    }

    /// How long a replicated pose stands before the next frame can replace it, seconds: the
    /// sweep an extent is grown by (see `crate::replication::interest`).
    pub fn sweep_s(&self) -> f32 {
        (self.replication_interval.max(1) + 1) as f32 * self.dt
    }

    /// How many clusters this one knows of: itself, its neighbours and those on its world
    /// map, each once.
    pub(crate) fn clusters_known(&self) -> usize {
        let mut ids: Vec<ClusterId> = std::iter::once(self.cluster_id)
            .chain(self.neighbours.iter().copied())
            .chain(self.world.iter().map(|c| c.id))
            .collect();
        ids.sort_unstable();
        ids.dedup();
        ids.len()
    }

    /// Whether `v`'s every component is within `max_magnitude` (NaN is not): what is accepted
    /// from another cluster.
    pub(crate) fn within_bound(&self, v: [f32; 3]) -> bool {
        v.iter().all(|c| c.abs() <= self.max_magnitude)
    }
}
