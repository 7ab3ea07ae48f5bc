//! The scene file's types and the checks a run relies on.

use serde::{Deserialize, Serialize};

use super::SceneShape;
use crate::error::{BenchError, BenchResult};

/// x, y, z.
pub type Vec3 = [f32; 3];

/// A whole scene.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// The scene's name.
    pub name: String,
    /// How many ticks a run lasts.
    #[serde(default = "default_ticks")]
    pub ticks: u64,
    /// Step length, seconds.
    #[serde(default = "default_dt")]
    pub dt: f32,
    /// Gravity, m/s².
    #[serde(default = "default_gravity")]
    pub gravity: Vec3,
    /// Largest linear speed a body may reach, m/s (Rapier's cap; 400 unless set).
    #[serde(default = "default_max_speed")]
    pub max_speed: f32,
    /// The clusters, one pod each.
    #[serde(rename = "cluster")]
    pub clusters: Vec<Cluster>,
    /// The entities.
    #[serde(rename = "entity", default)]
    pub entities: Vec<Entity>,
    /// Scripted events.
    #[serde(rename = "event", default)]
    pub events: Vec<Event>,
}

fn default_ticks() -> u64 {
    600
}

fn default_dt() -> f32 {
    1.0 / 60.0
}

fn default_max_speed() -> f32 {
    400.0
}

fn default_gravity() -> Vec3 {
    [0.0, -9.81, 0.0]
}

/// One cluster and the part of the world it observes.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Cluster {
    /// Its name in this scene.
    pub name: String,
    /// The region it observes.
    pub region: Region,
    /// How far beyond the region neighbour entities are still modelled, metres.
    #[serde(default)]
    pub spread: f32,
    /// The host its pod runs on (`seam run` lays out several hosts when clusters name them;
    /// see [`Scene::host_layout`]). Unset: one host, or the layout of `--hosts N`.
    #[serde(default)]
    pub host: Option<String>,
}

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    /// Lowest corner.
    pub min: Vec3,
    /// Highest corner.
    pub max: Vec3,
}

/// How the owner simulates an entity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Simulated.
    #[default]
    Dynamic,
    /// Owned, replicated, and does not move.
    Fixed,
    /// Owned, replicated, moved by its velocity only.
    Kinematic,
    /// Static level geometry every cluster loads itself: owned by none, never replicated
    /// (no `owner`; `mass` is not needed).
    Scenery,
}

/// Repeats an entity over a lattice: `count` along x, y, z, `spacing` apart.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    /// Copies along x, y, z.
    pub count: [u32; 3],
    /// Distance between copies, m.
    pub spacing: Vec3,
}

/// An entity (or, with `grid`, a lattice of them).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Entity {
    /// Its name in this scene (copies of a grid get `name#i`).
    pub name: String,
    /// The cluster that owns it at the start (none for scenery).
    #[serde(default)]
    pub owner: Option<String>,
    /// Collision shape.
    pub shape: SceneShape,
    /// Mass, kg (not needed for scenery).
    #[serde(default)]
    pub mass: Option<f32>,
    /// Position of the body origin (of the first copy of a grid), m.
    pub position: Vec3,
    /// Orientation `[x, y, z, w]`; identity if left out.
    #[serde(default = "identity")]
    pub rotation: [f32; 4],
    /// Linear velocity, m/s.
    #[serde(default)]
    pub velocity: Vec3,
    /// Angular velocity, rad/s.
    #[serde(default)]
    pub angvel: Vec3,
    /// How its owner simulates it.
    #[serde(default)]
    pub role: Role,
    /// Continuous collision detection.
    #[serde(default)]
    pub ccd: bool,
    /// Repeat it over a lattice.
    #[serde(default)]
    pub grid: Option<Grid>,
    /// Friction coefficient (0.5 unless set).
    #[serde(default = "default_friction")]
    pub friction: f32,
    /// Restitution, 0 (no bounce) to 1.
    #[serde(default)]
    pub restitution: f32,
    /// Linear damping, 1/s.
    #[serde(default)]
    pub linear_damping: f32,
    /// Angular damping, 1/s.
    #[serde(default)]
    pub angular_damping: f32,
    /// Collision groups (every group, meeting every group, unless set).
    #[serde(default)]
    pub groups: Option<SceneGroups>,
    /// A sensor: reports what enters and leaves it, pushes nothing.
    #[serde(default)]
    pub sensor: bool,
}

/// Collision groups: two bodies meet when each one's `memberships` share a bit with the
/// other's `filter`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneGroups {
    /// The groups it is in (bits).
    pub memberships: u32,
    /// The groups it meets (bits).
    pub filter: u32,
}

fn default_friction() -> f32 {
    0.5
}

pub(super) fn identity() -> [f32; 4] {
    [0.0, 0.0, 0.0, 1.0]
}

impl Entity {
    /// Mass, kg (scenery, which has none, counts as 1 kg/m³: it never moves).
    pub fn mass(&self) -> f32 {
        self.mass.unwrap_or_else(|| self.shape.volume())
    }

    /// Whether it is scenery.
    pub fn is_scenery(&self) -> bool {
        self.role == Role::Scenery
    }

    /// Where each copy it makes starts, in the order copies are numbered (`name#i`): x
    /// outermost, z innermost; one position without a grid.
    pub fn positions(&self) -> Vec<Vec3> {
        let Some(grid) = self.grid else {
            return vec![self.position];
        };
        let mut positions = Vec::with_capacity(self.copies() as usize);
        for i in 0..grid.count[0] {
            for j in 0..grid.count[1] {
                for k in 0..grid.count[2] {
                    let offset = [i, j, k].map(|n| n as f32);
                    positions
                        .push([0, 1, 2].map(|a| self.position[a] + offset[a] * grid.spacing[a]));
                }
            }
        }
        positions
    }

    /// How many entities this entry makes.
    pub fn copies(&self) -> u64 {
        self.grid
            .map_or(1, |g| g.count.iter().map(|&c| u64::from(c)).product())
    }
}

/// Something that happens at a tick.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Event {
    /// A cluster fires a projectile (a new entity it owns).
    Projectile {
        /// When.
        tick: u64,
        /// Repeat every this many ticks from `tick` on (once if left out).
        #[serde(default)]
        every: Option<u64>,
        /// The firing cluster.
        by: String,
        /// Where it starts, m.
        position: Vec3,
        /// Its velocity, m/s.
        velocity: Vec3,
        /// Its radius, m.
        radius: f32,
        /// Its mass, kg.
        mass: f32,
        /// Continuous collision detection.
        #[serde(default)]
        ccd: bool,
    },
    /// A cluster pushes everything within `radius` of `center` away from it.
    Explosion {
        /// When.
        tick: u64,
        /// Repeat every this many ticks from `tick` on (once if left out).
        #[serde(default)]
        every: Option<u64>,
        /// The cluster where it goes off.
        by: String,
        /// Centre, m.
        center: Vec3,
        /// Reach, m.
        radius: f32,
        /// Impulse on a body at the centre, N·s, falling linearly to zero at the reach.
        impulse: f32,
    },
    /// A cluster casts rays and pushes what they hit.
    RaycastVolley {
        /// When.
        tick: u64,
        /// Repeat every this many ticks from `tick` on (once if left out).
        #[serde(default)]
        every: Option<u64>,
        /// The shooting cluster.
        by: String,
        /// Where the rays start, m.
        origin: Vec3,
        /// Their directions.
        directions: Vec<Vec3>,
        /// How far they reach, m.
        max_distance: f32,
        /// Impulse given to each body hit, N·s, along the ray.
        impulse: f32,
    },
    /// The owner of an entity hands it to another cluster.
    Handoff {
        /// When.
        tick: u64,
        /// The entity (by scene name).
        entity: String,
        /// The new owner.
        to: String,
    },
    /// Whichever cluster owns an entity then sets its linear velocity: a platform or an
    /// elevator turning round (every copy of a grid entry).
    Steer {
        /// When.
        tick: u64,
        /// The entity (by scene name).
        entity: String,
        /// Its new velocity, m/s.
        velocity: [f32; 3],
    },
}

impl Event {
    /// When it first happens.
    pub fn tick(&self) -> u64 {
        match *self {
            Event::Projectile { tick, .. }
            | Event::Explosion { tick, .. }
            | Event::RaycastVolley { tick, .. }
            | Event::Handoff { tick, .. }
            | Event::Steer { tick, .. } => tick,
        }
    }

    /// How many ticks apart it repeats, if it does.
    pub fn every(&self) -> Option<u64> {
        match *self {
            Event::Projectile { every, .. }
            | Event::Explosion { every, .. }
            | Event::RaycastVolley { every, .. } => every,
            Event::Handoff { .. } | Event::Steer { .. } => None,
        }
    }

    /// Which repetition happens at `tick` (0 for the first), if one does.
    pub fn shot_at(&self, tick: u64) -> Option<u64> {
        let since = tick.checked_sub(self.tick())?;
        match self.every() {
            Some(every) if every > 0 => since.is_multiple_of(every).then_some(since / every),
            _ => (since == 0).then_some(0),
        }
    }
}

/// Byte offset of the line that sets `key` to the number `value`, for error positions.
fn find_number(text: &str, key: &str, value: u64) -> usize {
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let mut parts = line.splitn(2, '=');
        if let (Some(k), Some(v)) = (parts.next(), parts.next())
            && k.trim() == key
            && v.trim().parse() == Ok(value)
        {
            return offset + line.find(key).unwrap_or(0);
        }
        offset += line.len();
    }
    0
}

/// Byte offset of the line that sets `key` to the quoted `value`, for error positions.
fn find(text: &str, key: &str, value: &str) -> usize {
    let quoted = format!("\"{value}\"");
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        if line.contains(key) && line.contains(&quoted) {
            return offset + line.find(&quoted).unwrap_or(0);
        }
        offset += line.len();
    }
    0
}

impl Scene {
    /// Entities the scene spawns at the start (grid copies included).
    pub fn entity_count(&self) -> u64 {
        self.entities.iter().map(Entity::copies).sum()
    }

    /// The scene with `layers` copies of every grid entity stacked along y, `spacing[1]` apart:
    /// the same traffic across the same seams, `layers` times the entities. Refused for a grid
    /// entity with no y spacing (its copies would overlap).
    pub fn stacked(mut self, layers: u32) -> BenchResult<Scene> {
        if layers == 0 {
            return Err(BenchError::flag("--layers", "must be at least 1"));
        }
        for entity in &mut self.entities {
            if let Some(grid) = &mut entity.grid
                && layers > 1
            {
                if grid.spacing[1] <= 0.0 {
                    return Err(BenchError::flag(
                        "--layers",
                        format!(
                            "entity {:?}: cannot stack layers: its grid has no y spacing",
                            entity.name
                        ),
                    ));
                }
                grid.count[1] = grid.count[1].saturating_mul(layers);
            }
        }
        Ok(self)
    }

    /// The host of each cluster, in the scene's order. Clusters that name a `host` keep it
    /// (then every cluster must name one, and `hosts`, if given, must match their count);
    /// otherwise `hosts` (default 1) simulated hosts named `a`, `b`, … each take a run of
    /// neighbouring clusters in the scene's order, as evenly as they divide.
    pub fn host_layout(&self, hosts: Option<u32>) -> BenchResult<Vec<String>> {
        let named: Vec<&str> = self
            .clusters
            .iter()
            .filter_map(|c| c.host.as_deref())
            .collect();
        if !named.is_empty() {
            if named.len() != self.clusters.len() {
                return Err(BenchError::flag(
                    "--hosts",
                    format!(
                        "scene {:?}: {} of {} clusters name a `host`; name one for every cluster or for none",
                        self.name,
                        named.len(),
                        self.clusters.len()
                    ),
                ));
            }
            if let Some(bad) = named.iter().find(|h| {
                h.is_empty()
                    || h.len() > 16
                    || !h
                        .bytes()
                        .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_')
            }) {
                return Err(BenchError::flag(
                    "--hosts",
                    format!(
                        "scene {:?}: host {bad:?}: a host name is 1 to 16 of [A-Za-z0-9_-] (it names the host's shared memory)",
                        self.name
                    ),
                ));
            }
            let distinct: std::collections::BTreeSet<&str> = named.iter().copied().collect();
            if let Some(n) = hosts
                && n as usize != distinct.len()
            {
                return Err(BenchError::flag(
                    "--hosts",
                    format!(
                        "{n}: scene {:?} lays its clusters out on {} hosts itself",
                        self.name,
                        distinct.len()
                    ),
                ));
            }
            return Ok(named.iter().map(|h| (*h).to_owned()).collect());
        }
        let n = hosts.unwrap_or(1) as usize;
        if n == 0 || n > self.clusters.len() {
            return Err(BenchError::flag(
                "--hosts",
                format!(
                    "{n}: scene {:?} has {} clusters; give 1 to {} hosts",
                    self.name,
                    self.clusters.len(),
                    self.clusters.len()
                ),
            ));
        }
        let count = self.clusters.len();
        Ok((0..count).map(|i| host_name(i * n / count)).collect())
    }

    /// Checks what a run relies on; on failure, the byte offset to report and the message.
    pub(super) fn check(&self, text: &str) -> Result<(), (usize, String)> {
        self.check_clusters(text)?;
        let mut entity_names: Vec<&str> = Vec::new();
        for entity in &self.entities {
            if entity_names.contains(&entity.name.as_str()) {
                return Err((
                    find(text, "name", &entity.name),
                    format!("entity {:?}: field `name`: defined twice", entity.name),
                ));
            }
            entity_names.push(&entity.name);
            self.check_entity(text, entity)?;
        }
        for event in &self.events {
            self.check_event(text, event, &entity_names)?;
        }
        Ok(())
    }

    /// `name`, the value of field `key`, names a cluster of the scene.
    fn known_cluster(&self, text: &str, key: &str, name: &str) -> Result<(), (usize, String)> {
        if self.clusters.iter().any(|c| c.name == name) {
            return Ok(());
        }
        let names: Vec<&str> = self.clusters.iter().map(|c| c.name.as_str()).collect();
        Err((
            find(text, key, name),
            format!(
                "field `{key}`: no cluster named {name:?} (clusters: {})",
                names.join(", ")
            ),
        ))
    }

    /// The world's settings, and every cluster: named once, its region the right way round.
    fn check_clusters(&self, text: &str) -> Result<(), (usize, String)> {
        if self.clusters.is_empty() {
            return Err((0, "a scene needs at least one [[cluster]]".into()));
        }
        if !(positive(self.dt) && finite(&self.gravity) && positive(self.max_speed)) {
            return Err((
                0,
                "fields `dt` and `max_speed` must be positive and `gravity` finite".into(),
            ));
        }
        for (i, cluster) in self.clusters.iter().enumerate() {
            if self.clusters[..i].iter().any(|c| c.name == cluster.name) {
                return Err((
                    find(text, "name", &cluster.name),
                    format!("field `name`: cluster {:?} is defined twice", cluster.name),
                ));
            }
            let r = cluster.region;
            if !finite(&r.min) || !finite(&r.max) || (0..3).any(|k| r.min[k] > r.max[k]) {
                return Err((
                    find(text, "name", &cluster.name),
                    format!(
                        "field `region` of cluster {:?}: min must not exceed max",
                        cluster.name
                    ),
                ));
            }
        }
        Ok(())
    }

    /// One entity: owned as its kind requires, sized, massed, placed and turned sensibly.
    fn check_entity(&self, text: &str, entity: &Entity) -> Result<(), (usize, String)> {
        let at = find(text, "name", &entity.name);
        let bad = |message: &str| Err((at, format!("entity {:?}: {message}", entity.name)));
        match (&entity.owner, entity.is_scenery()) {
            (Some(owner), false) => self.known_cluster(text, "owner", owner)?,
            (None, false) => return bad("field `owner` is required (scenery alone has none)"),
            (Some(_), true) => {
                return bad(
                    "field `owner`: scenery is owned by no cluster (every cluster loads it)",
                );
            }
            (None, true) => {}
        }
        if let Some(problem) = entity.shape.problem() {
            return bad(&format!("field `shape`: {problem}"));
        }
        if entity.role == Role::Dynamic && !entity.shape.has_volume() {
            return bad(
                "field `shape`: a trimesh or heightfield has no volume: it is for scenery, \
                 fixed and kinematic bodies",
            );
        }
        let material = [
            entity.friction,
            entity.restitution,
            entity.linear_damping,
            entity.angular_damping,
        ];
        if !material.iter().all(|m| m.is_finite() && *m >= 0.0) {
            return bad(
                "fields `friction`, `restitution`, `linear_damping`, `angular_damping` must be \
                 finite and at least 0",
            );
        }
        match entity.mass {
            Some(mass) if !positive(mass) => return bad("field `mass` must be positive"),
            None if !entity.is_scenery() => {
                return bad("field `mass` is required (scenery alone has none)");
            }
            _ => {}
        }
        let vectors = [entity.position, entity.velocity, entity.angvel];
        if !vectors.iter().all(|v| finite(v)) || !finite(&entity.rotation) {
            return bad("fields `position`, `rotation`, `velocity`, `angvel` must be finite");
        }
        let [x, y, z, w] = entity.rotation;
        if ((x * x + y * y + z * z + w * w).sqrt() - 1.0).abs() > 1e-3 {
            return bad("field `rotation` must be a unit quaternion [x, y, z, w]");
        }
        if let Some(grid) = entity.grid
            && (grid.count.contains(&0) || !finite(&grid.spacing))
        {
            return bad("field `grid`: counts must be at least 1, spacing finite");
        }
        Ok(())
    }

    /// One scripted event: by a known cluster, its values finite, on a known owned entity.
    fn check_event(
        &self,
        text: &str,
        event: &Event,
        entity_names: &[&str],
    ) -> Result<(), (usize, String)> {
        if event.every() == Some(0) {
            return Err((
                find_number(text, "every", 0),
                "field `every` must be at least 1 tick".into(),
            ));
        }
        let (by, ok, message) = match event {
            Event::Projectile {
                by,
                position,
                velocity,
                radius,
                mass,
                ..
            } => (
                by,
                finite(position) && finite(velocity) && positive(*radius) && positive(*mass),
                "projectile: `position`, `velocity` finite, `radius`, `mass` positive",
            ),
            Event::Explosion {
                by,
                center,
                radius,
                impulse,
                ..
            } => (
                by,
                finite(center) && positive(*radius) && impulse.is_finite(),
                "explosion: `center` finite, `radius` positive, `impulse` finite",
            ),
            Event::RaycastVolley {
                by,
                origin,
                directions,
                max_distance,
                impulse,
                ..
            } => (
                by,
                finite(origin)
                    && directions
                        .iter()
                        .all(|d| finite(d) && d.iter().any(|c| *c != 0.0))
                    && positive(*max_distance)
                    && impulse.is_finite(),
                "raycast_volley: finite `origin`, non-zero `directions`, positive \
                 `max_distance`, finite `impulse`",
            ),
            Event::Handoff { entity, to, .. } => {
                self.known_cluster(text, "to", to)?;
                return self.check_owned_entity(text, entity, entity_names);
            }
            Event::Steer {
                entity, velocity, ..
            } => {
                if !finite(velocity) {
                    return Err((
                        find(text, "entity", entity),
                        "steer: `velocity` finite".into(),
                    ));
                }
                return self.check_owned_entity(text, entity, entity_names);
            }
        };
        self.known_cluster(text, "by", by)?;
        if !ok {
            return Err((find(text, "by", by), message.into()));
        }
        Ok(())
    }

    /// The entity a hand-off or a steer names: one of the scene's, and not scenery.
    fn check_owned_entity(
        &self,
        text: &str,
        entity: &str,
        entity_names: &[&str],
    ) -> Result<(), (usize, String)> {
        if !entity_names.contains(&entity) {
            return Err((
                find(text, "entity", entity),
                format!("field `entity`: no entity named {entity:?}"),
            ));
        }
        if self
            .entities
            .iter()
            .any(|e| e.name == entity && e.is_scenery())
        {
            return Err((
                find(text, "entity", entity),
                format!("field `entity`: {entity:?} is scenery, which nobody owns"),
            ));
        }
        Ok(())
    }
}

/// Whether every value is finite.
fn finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Whether `x` is finite and above zero.
fn positive(x: f32) -> bool {
    x.is_finite() && x > 0.0
}

/// The name of simulated host number `index`: `a`, `b`, … `z`, then `h26`, `h27`, ….
pub fn host_name(index: usize) -> String {
    match u8::try_from(index) {
        Ok(i) if i < 26 => char::from(b'a' + i).to_string(),
        _ => format!("h{index}"),
    }
}
