//! A pod: one cluster playing its part of a scene, or one world playing all of it.
//!
//! [`Pod::new`] builds the cluster of one scene cluster (its region, spread and neighbours —
//! the clusters whose regions, grown by both spreads, touch its own), spawns the entities it
//! owns, and on each [`Pod::tick`] fires the scene's events of that tick that are its to fire:
//!
//! - a projectile is spawned, owned by the firing cluster, before the tick;
//! - a hand-off is started by whichever pod owns the entity at that tick;
//! - an explosion and a raycast volley run as user code in the tick, so their pushes on
//!   entities another cluster owns are routed to that owner like any write.
//!
//! [`Part::Reference`] plays every cluster in one world (no neighbours, no hand-offs needed):
//! the single-world run that split runs are compared against.
//!
//! Ids come from [`SceneIds`], so separately started pods agree on them.

mod events;
mod flips;
mod ids;
mod stages;

use std::collections::{BTreeMap, HashMap, HashSet};
use std::time::Duration;

use seam_proxy::{
    AuthorityMode, Cluster, ClusterConfig, ClusterError, ClusterEvent, ProxyMode, Region,
    TickEvent, WorldCluster, world_map,
};
use seam_sim::BodyRole;
use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, Shape, StateEncoding};

use crate::scene::{self, Event, Scene, SceneShape};
pub use events::{EventCounts, RoutedPush};
pub use flips::FlipRecord;
pub use ids::SceneIds;
pub use stages::{OpStages, OpStagesSummary, TickDelaySummary};

/// Which part of a scene a pod plays.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Part {
    /// The scene cluster of this name.
    Cluster(String),
    /// Every cluster, in one world.
    Reference,
}

/// How a pod runs, besides its scene and part.
#[derive(Debug, Clone)]
pub struct PodSettings {
    /// Transport URL.
    pub transport: String,
    /// Salts every id, so concurrent runs of one scene do not meet (see [`SceneIds`]).
    pub run_id: String,
    /// How neighbour entities are modelled.
    pub proxy_mode: ProxyMode,
    /// Which hand-offs the cluster makes besides the scene's.
    pub authority: AuthorityMode,
    /// A replication frame every this many ticks.
    pub replication_interval: u64,
    /// Whether contacts push across the seam (see `ClusterConfig::coupling`).
    pub coupling: bool,
    /// Routed ops exchanged before the step (see `ClusterConfig::exchange`).
    pub exchange: bool,
    /// How replication frames write motion (see `ClusterConfig::state_encoding`).
    pub state_encoding: StateEncoding,
    /// A keyframe at most every this many ticks (see `ClusterConfig::keyframe_ticks`).
    pub keyframe_ticks: u64,
    /// Ticks of silence after which a neighbour is taken for dead (0: never; see
    /// `ClusterConfig::neighbour_timeout_ticks`).
    pub neighbour_timeout_ticks: u64,
    /// Rejoin a running world after a restart: spawn nothing and fire no events (what this
    /// cluster owned was adopted by its neighbours; its projectiles' ids were used).
    pub rejoin: bool,
    /// Record every authority flip's states (see [`FlipRecord`]), for free-running accuracy.
    pub track_flips: bool,
    /// A noise floor's single world: every dynamic body moved this far from where the scene
    /// puts it, m, each in a direction of its own (see [`perturbed`]), and everything spawned
    /// in reverse order. 0 for every other pod.
    pub perturbation_m: f32,
    /// Which of the floor's worlds this is: each draws its bodies' directions afresh.
    pub perturbation_world: u32,
}

impl PodSettings {
    /// Settings with Fixed proxies, the `Spatial` authority policy, replication every tick and
    /// a 60-tick neighbour timeout.
    pub fn new(transport: impl Into<String>, run_id: impl Into<String>) -> Self {
        Self {
            transport: transport.into(),
            run_id: run_id.into(),
            proxy_mode: ProxyMode::Fixed,
            authority: AuthorityMode::default(),
            replication_interval: 1,
            coupling: true,
            exchange: true,
            state_encoding: StateEncoding::Exact,
            keyframe_ticks: seam_proxy::DEFAULT_KEYFRAME_TICKS,
            neighbour_timeout_ticks: 60,
            rejoin: false,
            track_flips: false,
            perturbation_m: 0.0,
            perturbation_world: 0,
        }
    }
}

/// Why a pod could not start.
#[derive(Debug, thiserror::Error)]
pub enum PodError {
    /// The scene has no cluster of that name.
    #[error("scene {scene:?} has no cluster named {name:?} (clusters: {known})")]
    UnknownCluster {
        /// The scene.
        scene: String,
        /// The name asked for.
        name: String,
        /// The names it has.
        known: String,
    },
    /// The cluster could not start (transport, spawn).
    #[error(transparent)]
    Cluster(#[from] ClusterError),
    /// A scene shape is none a body can have.
    #[error("shape: {0}")]
    Shape(String),
}

/// One cluster playing its part of a scene.
pub struct Pod {
    cluster: Cluster,
    name: String,
    /// Scene clusters by name.
    clusters: HashMap<String, ClusterId>,
    /// Scene entities by name (every copy of a grid entry).
    entities: HashMap<String, Vec<EntityId>>,
    /// The scene's events with their index, in order of first tick.
    events: Vec<(usize, Event)>,
    /// Which scene clusters this pod plays.
    plays: Vec<String>,
    /// Whether it plays all of them in one world.
    reference: bool,
    ids: SceneIds,
    counts: EventCounts,
    /// The pushes this pod's events routed to other owners in its last tick.
    routed_pushes: Vec<RoutedPush>,
    stages: OpStages,
    /// The same, by the cluster whose frame brought each op.
    stages_by_sender: BTreeMap<ClusterId, OpStages>,
    /// Authority flips seen, when asked for.
    flips: Option<flips::FlipLog>,
    /// What the cluster did in its last tick (and since the tick before).
    last_events: Vec<TickEvent>,
    /// Scene name of every cluster, by id.
    cluster_names: HashMap<ClusterId, String>,
    owned_at_start: usize,
    /// Projectiles this pod fired.
    fired: Vec<EntityId>,
    /// Every projectile of the scene fired so far, by any cluster (ids are derived, so every
    /// pod knows them), with its name (see [`Pod::entity_name`]).
    all_projectiles: HashMap<EntityId, String>,
    /// Contacts that started between a projectile and anything but a projectile, in this world
    /// (reported ones included), with the first tick each pair was seen.
    projectile_hits: BTreeMap<(EntityId, EntityId), u64>,
    /// Projectiles that were in this world at one of the looks every [`SEEN_EVERY`] ticks.
    projectiles_seen: HashSet<EntityId>,
}

/// The scene-cluster name a reference pod's cluster id is derived from (no scene cluster can
/// have it).
pub(crate) const REFERENCE_CLUSTER: &str = "\u{0}reference";

/// How often a pod looks for projectiles in its world, ticks.
const SEEN_EVERY: u64 = 10;

/// Every cluster of `scene` with its region and neighbours (see `seam_proxy::world_map`).
pub(crate) fn scene_world_map(
    scene: &Scene,
    ids: &HashMap<String, ClusterId>,
) -> Vec<WorldCluster> {
    let clusters: Vec<(ClusterId, Region, f32)> = scene
        .clusters
        .iter()
        .map(|c| {
            let region = Region {
                min: c.region.min,
                max: c.region.max,
            };
            (ids[&c.name], region, c.spread)
        })
        .collect();
    world_map(&clusters)
}

/// The wire shape of a scene shape: a primitive as it is, a catalog shape registered in
/// `cluster`'s catalog first (every pod of a run registers the same ones).
pub fn wire_shape(shape: &SceneShape, cluster: &mut Cluster) -> Result<Shape, PodError> {
    if let Some(primitive) = shape.primitive() {
        return Ok(primitive);
    }
    let def = shape.catalog_def().ok_or_else(|| {
        PodError::Shape("a compound's parts are balls, cuboids and capsules".into())
    })?;
    Ok(cluster.register_shape(def)?)
}

/// The body spec of a scene entity: its shape (registered in `cluster`'s catalog if it is
/// one), density from its mass, CCD, material, groups, sensor.
fn entity_body(entity: &scene::Entity, cluster: &mut Cluster) -> Result<BodySpec, PodError> {
    let volume = entity.shape.volume();
    // A mesh or a heightfield has no volume: it is never simulated, so its density is moot.
    let density = if volume > 0.0 {
        entity.mass() / volume
    } else {
        1.0
    };
    let mut body = BodySpec::new(wire_shape(&entity.shape, cluster)?)
        .density(density)
        .ccd(entity.ccd)
        .friction(entity.friction)
        .restitution(entity.restitution)
        .damping(entity.linear_damping, entity.angular_damping)
        .sensor(entity.sensor);
    if let Some(groups) = entity.groups {
        body = body.groups(groups.memberships, groups.filter);
    }
    Ok(body)
}

/// The body role of an owned scene role (`None` for scenery, which nobody owns).
fn body_role(role: scene::Role) -> Option<BodyRole> {
    match role {
        scene::Role::Dynamic => Some(BodyRole::Dynamic),
        scene::Role::Fixed => Some(BodyRole::Fixed),
        scene::Role::Kinematic => Some(BodyRole::KinematicVelocityBased),
        scene::Role::Scenery => None,
    }
}

/// The pod's settings and the scene's world settings, into `config`.
fn apply_settings(config: &mut ClusterConfig, scene: &Scene, settings: &PodSettings) {
    config.proxy_mode = settings.proxy_mode;
    config.authority = settings.authority;
    config.replication_interval = settings.replication_interval.max(1);
    config.coupling = settings.coupling;
    config.exchange = settings.exchange;
    config.state_encoding = settings.state_encoding;
    config.keyframe_ticks = settings.keyframe_ticks;
    config.dt = scene.dt;
    config.gravity = scene.gravity;
    config.max_linear_velocity = scene.max_speed;
    config.neighbour_timeout_ticks = settings.neighbour_timeout_ticks;
}

/// `position` of the scene body `body` (its name, `#i` for a grid copy) moved `by` metres in a
/// direction of its own in floor world `world`: three 16-bit fields of a hash of the scene,
/// the body and the world, centred, as a vector, normalised. Drawn from names, not from ids
/// (which come from the run's name), so a body moves the same way in every run of a scene:
/// a free-running run and a lock-step trial of one scene stand beside the same floor.
pub fn perturbed(position: [f32; 3], body: &str, world: u32, by: f32) -> [f32; 3] {
    if by == 0.0 {
        return position;
    }
    let bits = EntityId::named(&format!("noise floor {world}"), body).as_u128();
    let d = [0, 16, 32].map(|shift| ((bits >> shift) & 0xffff) as f32 - 32767.5);
    let length = d
        .iter()
        .map(|c| c * c)
        .sum::<f32>()
        .sqrt()
        .max(f32::MIN_POSITIVE);
    [0, 1, 2].map(|a| position[a] + d[a] / length * by)
}

/// Spawns what `cluster` (playing the clusters `plays`) loads of `scene`: every scenery
/// entity, and the entities it owns unless it `rejoin`s (its neighbours hand those back).
/// With `settings.perturbation_m`, the noise floor's world: dynamic bodies moved that far
/// (see [`perturbed`]) and everything spawned in reverse order (Rapier's solver visits
/// contacts in the order bodies were inserted, and a split world inserts them in another
/// order than one world does). Every entity's ids by name, and how many it owns.
fn spawn_entities(
    cluster: &mut Cluster,
    scene: &Scene,
    ids: &SceneIds,
    plays: &[String],
    settings: &PodSettings,
) -> Result<(HashMap<String, Vec<EntityId>>, usize), PodError> {
    let cluster_id = cluster.id();
    let mut entities: HashMap<String, Vec<EntityId>> = HashMap::new();
    let mut spawns: Vec<(EntityState, Option<BodyRole>)> = Vec::new();
    for entity in &scene.entities {
        let body = entity_body(entity, cluster)?;
        let copies = entities.entry(entity.name.clone()).or_default();
        for (index, at) in entity.positions().into_iter().enumerate() {
            let id = ids.entity(&entity.name, index as u64);
            copies.push(id);
            // Scenery is every cluster's, and a restarted pod loads it again; owned entities
            // are spawned by their owner at the start only.
            let owner = entity.owner.as_ref().filter(|o| plays.contains(*o));
            if !entity.is_scenery() && (owner.is_none() || settings.rejoin) {
                continue;
            }
            let at = if entity.role == scene::Role::Dynamic {
                let body = format!("{}/{}#{index}", scene.name, entity.name);
                perturbed(
                    at,
                    &body,
                    settings.perturbation_world,
                    settings.perturbation_m,
                )
            } else {
                at
            };
            let state = EntityState::new(id, cluster_id, body)
                .at(at)
                .rotated(entity.rotation)
                .velocity(entity.velocity)
                .spin(entity.angvel);
            spawns.push((state, body_role(entity.role)));
        }
    }
    if settings.perturbation_m != 0.0 {
        spawns.reverse();
    }
    let mut owned_at_start = 0;
    for (state, role) in spawns {
        match role {
            Some(role) => {
                cluster.spawn_owned(&state, role)?;
                owned_at_start += 1;
            }
            None => cluster.spawn_scenery(&state)?,
        }
    }
    Ok((entities, owned_at_start))
}

/// The scene's entities by name (`name`, or `name#i` for the copies of a grid), for the
/// cluster's logs; a name the rule refuses (`seam_proxy::name_ok`: over 64 characters, say)
/// is left out, and the entity shown by its id.
fn scene_entity_names(scene: &Scene, ids: &SceneIds) -> BTreeMap<EntityId, String> {
    let mut names = BTreeMap::new();
    for entity in &scene.entities {
        let copies = entity.copies();
        for i in 0..copies {
            let name = if copies > 1 {
                format!("{}#{i}", entity.name)
            } else {
                entity.name.clone()
            };
            if seam_proxy::name_ok(&name) {
                names.insert(ids.entity(&entity.name, i), name);
            }
        }
    }
    names
}

impl Pod {
    /// Starts `part` of `scene`: opens the transport, subscribes to the neighbours and spawns
    /// the entities it owns.
    pub fn new(scene: &Scene, part: &Part, settings: &PodSettings) -> Result<Self, PodError> {
        let ids = SceneIds::new(&settings.run_id, &scene.name);
        let clusters: HashMap<String, ClusterId> = scene
            .clusters
            .iter()
            .map(|c| (c.name.clone(), ids.cluster(&c.name)))
            .collect();
        let world = scene_world_map(scene, &clusters);
        let cluster_names: HashMap<ClusterId, String> =
            clusters.iter().map(|(n, id)| (*id, n.clone())).collect();
        let (name, plays, cluster_id, neighbours, region, spread) = match part {
            Part::Reference => (
                "reference".to_owned(),
                scene.clusters.iter().map(|c| c.name.clone()).collect(),
                ids.cluster(REFERENCE_CLUSTER),
                Vec::new(),
                Region::EVERYWHERE,
                0.0,
            ),
            Part::Cluster(name) => {
                let me = scene
                    .clusters
                    .iter()
                    .find(|c| &c.name == name)
                    .ok_or_else(|| PodError::UnknownCluster {
                        scene: scene.name.clone(),
                        name: name.clone(),
                        known: scene
                            .clusters
                            .iter()
                            .map(|c| c.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
                    })?;
                let neighbours = world
                    .iter()
                    .find(|c| c.id == clusters[name])
                    .map(|c| c.neighbours.clone())
                    .unwrap_or_default();
                (
                    name.clone(),
                    vec![name.clone()],
                    clusters[name],
                    neighbours,
                    Region {
                        min: me.region.min,
                        max: me.region.max,
                    },
                    me.spread,
                )
            }
        };
        let mut config = ClusterConfig::new(cluster_id, neighbours, &settings.transport);
        if !matches!(part, Part::Reference) {
            config.world = world;
        }
        config.region = region;
        config.spread = spread;
        config.names = cluster_names
            .iter()
            .map(|(id, n)| (*id, n.clone()))
            .collect();
        config.entity_names = scene_entity_names(scene, &ids);
        apply_settings(&mut config, scene, settings);
        let mut cluster = Cluster::new(config)?;
        // A pod reads its cluster's events after every tick: op timings, hand-offs, ledgers.
        cluster.keep_events();

        let (entities, owned_at_start) =
            spawn_entities(&mut cluster, scene, &ids, &plays, settings)?;
        cluster.advertise()?;
        let mut events: Vec<(usize, Event)> = if settings.rejoin {
            Vec::new()
        } else {
            scene.events.iter().cloned().enumerate().collect()
        };
        events.sort_by_key(|(index, event)| (event.tick(), *index));
        Ok(Self {
            cluster,
            name,
            clusters,
            entities,
            events,
            plays,
            reference: *part == Part::Reference,
            ids,
            counts: EventCounts::default(),
            routed_pushes: Vec::new(),
            stages: OpStages::default(),
            stages_by_sender: BTreeMap::new(),
            flips: settings.track_flips.then(flips::FlipLog::default),
            last_events: Vec::new(),
            cluster_names,
            owned_at_start,
            fired: Vec::new(),
            all_projectiles: HashMap::new(),
            projectile_hits: BTreeMap::new(),
            projectiles_seen: HashSet::new(),
        })
    }

    /// Every entity this pod owns now.
    pub fn owned(&self) -> Vec<EntityId> {
        self.cluster.owned().collect()
    }

    /// Every neighbour entity this pod holds a proxy of, with the owner it names (scenery
    /// left out).
    pub fn proxied(&self) -> Vec<(EntityId, ClusterId)> {
        let me = self.cluster.id();
        self.cluster
            .sim()
            .entities()
            .filter(|(_, info)| info.owner != me && info.owner != ClusterId::SCENERY)
            .map(|(id, info)| (id, info.owner))
            .collect()
    }

    /// Projectiles seen in this world so far (see [`NodeReport::projectiles_seen`]).
    ///
    /// [`NodeReport::projectiles_seen`]: crate::node::NodeReport::projectiles_seen
    pub fn projectiles_seen(&self) -> Vec<EntityId> {
        self.projectiles_seen.iter().copied().collect()
    }

    /// The scene cluster this pod plays (`reference` for a reference pod).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The cluster, to read.
    pub fn cluster(&self) -> &Cluster {
        &self.cluster
    }

    /// The scene name of entity `id` (`name#i` for a grid copy), or its id (a projectile).
    pub fn entity_name(&self, id: EntityId) -> String {
        for (name, copies) in &self.entities {
            if let Some(i) = copies.iter().position(|&c| c == id) {
                return if copies.len() > 1 {
                    format!("{name}#{i}")
                } else {
                    name.clone()
                };
            }
        }
        match self.all_projectiles.get(&id) {
            Some(name) => name.clone(),
            None => id.to_string(),
        }
    }

    /// The id of scene entity `name` (its first copy, for a grid entry), or of the projectile
    /// `shot:E.S` (event E of the scene's list, counted from 0, its shot S), fired or not.
    pub fn entity_id(&self, name: &str) -> Option<EntityId> {
        if let Some((event, shot)) = name
            .strip_prefix("shot:")
            .and_then(|rest| rest.split_once('.'))
        {
            let (event, shot) = (event.parse().ok()?, shot.parse().ok()?);
            return Some(self.ids.event_entity(event, shot));
        }
        self.entities.get(name).and_then(|ids| ids.first().copied())
    }

    /// The id of the scene cluster `name`.
    pub fn cluster_id(&self, name: &str) -> Option<ClusterId> {
        self.clusters.get(name).copied()
    }

    /// Entities this pod spawned at the start.
    pub fn owned_at_start(&self) -> usize {
        self.owned_at_start
    }

    /// Contacts that started between a projectile (of any cluster) and anything in this world
    /// that is not a projectile, reported ones included: pair (smaller id first) → first tick.
    pub fn projectile_hits(&self) -> &BTreeMap<(EntityId, EntityId), u64> {
        &self.projectile_hits
    }

    /// Whether `id` is a projectile of the scene fired so far.
    pub fn is_projectile(&self, id: EntityId) -> bool {
        self.all_projectiles.contains_key(&id)
    }

    /// Position of every dynamic body this pod simulates, projectiles left out.
    pub fn simulated_positions(&self) -> Vec<(EntityId, [f32; 3])> {
        let me = self.cluster.id();
        let sim = self.cluster.sim();
        sim.entities()
            .filter(|(id, info)| {
                info.owner == me
                    && info.role == BodyRole::Dynamic
                    && !self.all_projectiles.contains_key(id)
            })
            .filter_map(|(id, _)| sim.state(id).map(|s| (id, s.position)))
            .collect()
    }

    /// The projectiles this pod fired, in firing order.
    pub fn projectiles(&self) -> &[EntityId] {
        &self.fired
    }

    /// The impulses this pod's events routed to other owners in its last tick: momentum in
    /// flight, which in lock-step their owners apply in their next tick.
    pub fn routed_pushes(&self) -> &[RoutedPush] {
        &self.routed_pushes
    }

    /// What the pod's events did so far.
    pub fn event_counts(&self) -> EventCounts {
        self.counts
    }

    /// The authority flips recorded so far (none unless `PodSettings::track_flips`).
    pub fn flips(&self) -> &[FlipRecord] {
        self.flips.as_ref().map_or(&[], |f| f.records.as_slice())
    }

    /// What this pod's cluster did in its last tick, and between it and the tick before: the
    /// routed ops it applied, the hand-offs it took and gave (one taken and given back within
    /// the tick included), every op and report by name (see `seam_proxy::ClusterEvent`).
    pub fn last_events(&self) -> &[TickEvent] {
        &self.last_events
    }

    /// Stage times of the routed ops this pod applied so far.
    pub fn op_stages(&self) -> &OpStages {
        &self.stages
    }

    /// The same, by the scene cluster whose frame brought the ops.
    pub fn op_stages_by_sender(&self) -> Vec<(String, OpStages)> {
        self.stages_by_sender
            .iter()
            .map(|(id, stages)| {
                let name = self.cluster_names.get(id).cloned();
                (name.unwrap_or_else(|| id.to_string()), stages.clone())
            })
            .collect()
    }

    /// Entities owned here and proxies of other clusters' entities, now (scenery is neither).
    pub fn population(&self) -> (usize, usize) {
        let me = self.cluster.id();
        let (mut owned, mut proxies) = (0, 0);
        for (_, info) in self.cluster.sim().entities() {
            if info.owner == me {
                owned += 1;
            } else if info.owner != ClusterId::SCENERY {
                proxies += 1;
            }
        }
        (owned, proxies)
    }

    /// The cluster, to run on a schedule (see `seam_proxy::Schedule`).
    pub fn cluster_mut(&mut self) -> &mut Cluster {
        &mut self.cluster
    }

    /// One free-running tick with this tick's events.
    pub fn tick(&mut self) -> Result<(), ClusterError> {
        let actions = self.before_tick();
        let (counts, routed) = (&mut self.counts, &mut self.routed_pushes);
        let entities = &self.entities;
        self.cluster.tick(|context, physics| {
            events::run(&actions, entities, context, physics, counts, routed)
        })?;
        self.after_tick();
        Ok(())
    }

    /// The first half of a lock-step tick with this tick's events (see
    /// [`Cluster::begin_lockstep`]): every pod of a trial begins before any finishes.
    pub fn begin_lockstep(&mut self, timeout: Duration) -> Result<(), ClusterError> {
        let actions = self.before_tick();
        let (counts, routed) = (&mut self.counts, &mut self.routed_pushes);
        let entities = &self.entities;
        self.cluster.begin_lockstep(timeout, |context, physics| {
            events::run(&actions, entities, context, physics, counts, routed)
        })
    }

    /// The second half (see [`Cluster::finish_lockstep`]).
    pub fn finish_lockstep(&mut self, timeout: Duration) -> Result<(), ClusterError> {
        self.cluster.finish_lockstep(timeout)?;
        self.after_tick();
        Ok(())
    }

    /// Watches the reach of this pod's explosions and volleys a little before they go off, so
    /// that the neighbour entities they reach are proxies here by then (see
    /// [`Cluster::watch`]).
    fn watch_ahead(&mut self, tick: u64) {
        let lead = self.cluster.config().replication_interval.max(1) + 1;
        let due = tick + lead;
        let reaches: Vec<Region> = self
            .events
            .iter()
            .filter(|(_, event)| event.shot_at(due).is_some())
            .filter_map(|(_, event)| match event {
                Event::Explosion {
                    by, center, radius, ..
                } if self.plays.contains(by) => Some(Region {
                    min: center.map(|c| c - radius),
                    max: center.map(|c| c + radius),
                }),
                Event::RaycastVolley {
                    by,
                    origin,
                    directions,
                    max_distance,
                    ..
                } if self.plays.contains(by) => {
                    let mut reach = Region {
                        min: *origin,
                        max: *origin,
                    };
                    for direction in directions {
                        let length = direction.iter().map(|c| c * c).sum::<f32>().sqrt();
                        for k in 0..3 {
                            let end = origin[k] + direction[k] / length * max_distance;
                            reach.min[k] = reach.min[k].min(end);
                            reach.max[k] = reach.max[k].max(end);
                        }
                    }
                    Some(reach)
                }
                _ => None,
            })
            .collect();
        for reach in reaches {
            self.cluster.watch(reach, due);
        }
    }

    /// Fires this tick's spawns and hand-offs; returns the events that run as user code.
    fn before_tick(&mut self) -> Vec<Event> {
        self.routed_pushes.clear();
        let tick = self.cluster.sim().tick();
        if !self.reference {
            self.watch_ahead(tick);
        }
        let firing: Vec<(usize, usize, u64)> = self
            .events
            .iter()
            .enumerate()
            .filter_map(|(at, (index, event))| event.shot_at(tick).map(|shot| (at, *index, shot)))
            .collect();
        let mut actions = Vec::new();
        for (at, index, shot) in firing {
            let event = &self.events[at].1;
            if matches!(event, Event::Projectile { .. }) {
                self.all_projectiles.insert(
                    self.ids.event_entity(index, shot),
                    format!("shot:{index}.{shot}"),
                );
            }
            match event {
                Event::Projectile {
                    by,
                    position,
                    velocity,
                    radius,
                    mass,
                    ccd,
                    ..
                } if self.plays.contains(by) => {
                    let shape = SceneShape::Ball { radius: *radius };
                    let body = BodySpec::new(Shape::ball(*radius))
                        .density(mass / shape.volume())
                        .ccd(*ccd);
                    let state = EntityState {
                        tick,
                        ..EntityState::new(
                            self.ids.event_entity(index, shot),
                            self.cluster.id(),
                            body,
                        )
                        .at(*position)
                        .velocity(*velocity)
                    };
                    match self.cluster.spawn_owned(&state, BodyRole::Dynamic) {
                        Ok(()) => {
                            self.counts.projectiles += 1;
                            self.fired.push(state.id);
                        }
                        Err(_) => self.counts.refused += 1,
                    }
                }
                Event::Handoff { entity, to, .. } if !self.reference => {
                    // In a reference world every cluster is this one: nothing to hand over.
                    let (Some(&to), Some(copies)) =
                        (self.clusters.get(to), self.entities.get(entity))
                    else {
                        self.counts.refused += 1;
                        continue;
                    };
                    let me = self.cluster.id();
                    for &id in copies {
                        let owner = self.cluster.sim().info(id).map(|i| i.owner);
                        if owner != Some(me) || to == me {
                            // Not this pod's to hand over.
                            continue;
                        }
                        match self.cluster.transfer_authority(id, to) {
                            Ok(()) => self.counts.handoffs += 1,
                            Err(_) => self.counts.refused += 1,
                        }
                    }
                }
                Event::Explosion { by, .. } | Event::RaycastVolley { by, .. }
                    if self.plays.contains(by) =>
                {
                    actions.push(event.clone());
                }
                Event::Steer { .. } => actions.push(event.clone()),
                _ => {}
            }
        }
        actions
    }

    fn after_tick(&mut self) {
        if let Some(flips) = &mut self.flips {
            flips.observe(self.cluster.sim(), self.cluster.id());
        }
        self.last_events = self.cluster.take_events();
        for event in &self.last_events {
            if let ClusterEvent::OpApplied { timing, .. } = &event.event {
                self.stages.record(timing);
                self.stages_by_sender
                    .entry(timing.from)
                    .or_default()
                    .record(timing);
            }
        }
        if self.all_projectiles.is_empty() {
            return;
        }
        let tick = self.cluster.sim().tick();
        if tick.is_multiple_of(SEEN_EVERY) {
            let sim = self.cluster.sim();
            self.projectiles_seen.extend(
                sim.entities()
                    .map(|(id, _)| id)
                    .filter(|id| self.all_projectiles.contains_key(id)),
            );
        }
        for contact in self.cluster.sim().contacts() {
            let (a, b) = (contact.a, contact.b);
            if contact.started
                && (self.all_projectiles.contains_key(&a) != self.all_projectiles.contains_key(&b))
            {
                self.projectile_hits
                    .entry((a.min(b), a.max(b)))
                    .or_insert(tick);
            }
        }
    }
}
