//! Comparing a split run with its single-world reference, tick by tick.

use std::collections::{BTreeMap, HashSet};

use seam_sim::box_grid::BoxGrid;
use seam_sim::wire::{ClusterId, EntityId, EntityState, IdMap, Shape};
use seam_sim::{BodyRole, ShapeCatalog};
use serde::Serialize;

use seam_proxy::Region;

use crate::error::{BenchError, BenchResult};
use crate::pod::Pod;
use crate::scene::Scene;

/// Accuracy of a split run against its reference.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Accuracy {
    /// Position error of the scene's dynamic bodies (owner's world against the reference), RMS
    /// over bodies and ticks, m. Projectiles are left out: once one hits in one run and not in
    /// the other, it flies hundreds of metres apart, and the hit metrics already count that.
    pub position_rms_m: f64,
    /// Largest position error, m.
    pub position_max_m: f64,
    /// The body with the largest position error (scene name, `#i` for a grid copy) and the
    /// tick it was largest at: where to look first.
    pub worst_body: Option<(String, u64)>,
    /// The body with the largest judged hand-off jump (a projectile `shot:E.S`: event E of
    /// the scene, its shot S) and the tick of the flip.
    pub worst_handoff: Option<(String, u64)>,
    /// The first tick any of those bodies was [`ONSET_M`] or more from its single-world copy
    /// (`None`: none ever was). On a chaotic scene final errors say little (a second single
    /// world perturbed at round-off ends as far off); when the worlds first part says more.
    pub onset_tick: Option<u64>,
    /// Orientation error, RMS, degrees.
    pub rotation_rms_deg: f64,
    /// Largest orientation error, degrees.
    pub rotation_max_deg: f64,
    /// Projectile hits (contact starts between a projectile and a body that is not one, by
    /// entity pair) in the reference.
    pub hits_reference: u64,
    /// Projectile hits in the split run (any cluster's world, reported ones included).
    pub hits_split: u64,
    /// Pairs hit in both.
    pub hits_matched: u64,
    /// hits_matched / hits_reference (`None` when the reference has none).
    pub hit_recall: Option<f64>,
    /// hits_matched / hits_split (`None` when the split run has none).
    pub hit_precision: Option<f64>,
    /// Mean |split tick − reference tick| of matched hits.
    pub hit_tick_offset_mean: f64,
    /// Largest |Σ m·v (split) − Σ m·v (reference)| over ticks, kg·m/s. A body in a hand-off
    /// counts with the momentum its hand-off carries, and a push routed to an owner that has
    /// not applied it yet with its impulse.
    pub momentum_error_max: f64,
    /// Mean of that error over the mean Σ m·|v| of the reference (unitless).
    pub momentum_error_rel: f64,
    /// The single world's own drift on the same scale: the mean of |Σ m·v (reference) −
    /// Σ m·v (reference, first tick)| over the mean Σ m·|v| — what gravity, floors, blasts and
    /// new projectiles change of the total by themselves. A momentum error is judged beyond it.
    pub momentum_drift_rel: f64,
    /// Authority flips seen, projectiles included.
    pub handoffs: u64,
    /// Of those, flips of a body that had already drifted more than [`TRACKED_M`] or
    /// [`TRACKED_MPS`] from its single-world copy before the flip, or that may meet one that
    /// had within two ticks: its motion over the flip tick differs from the copy's for reasons
    /// the hand-off has no part in (it meets other bodies, elsewhere, or with another speed),
    /// so the flip is not judged for a jump.
    pub handoffs_untracked: u64,
    /// Of those, flips to a cluster that held no proxy of the body (it was spawned there from
    /// the hand-off's state; `ClusterStats::handoffs_in_without_proxy`).
    #[serde(default)]
    pub handoffs_without_proxy: u64,
    /// Largest position discontinuity at a judged flip: how far the new owner's motion over
    /// the flip tick departs from the single world's, m.
    pub handoff_jump_position_m: f64,
    /// Largest velocity discontinuity at a judged flip, beyond the single world's, m/s.
    pub handoff_jump_velocity_mps: f64,
    /// The same departure at a tick without a flip, largest over the run: a body tracked
    /// as closely (within [`TRACKED_M`] and [`TRACKED_MPS`] of its single-world copy, and near
    /// none that is not) whose motion over one tick departs from the copy's, m. In a pile a body that close can meet
    /// a neighbour a tick before or after its copy does; on the noise floor's run this is what
    /// chaos alone gives, and a hand-off jump is judged beside it.
    pub step_jump_position_m: f64,
    /// Its velocity, m/s.
    pub step_jump_velocity_mps: f64,
    /// Body-ticks where an entity was dynamic in more than one cluster.
    pub duplicate_owner_ticks: u64,
    /// Body-ticks where a dynamic entity of the reference was in no cluster's world at all.
    pub missing_entity_ticks: u64,
    /// Body-ticks where it was only a proxy everywhere: between the old owner's hand-off frame
    /// and the new owner's tick that reads it (no step happens in between in lock-step).
    pub in_transit_ticks: u64,
    /// Bodies that escaped the split world at some tick while their single-world copy had not:
    /// below the lowest static surface (the lowest top of a Fixed body or scenery, if the scene
    /// has any) or outside every cluster's region. A body falling through a floor its owner
    /// did not model, or flying off because a proxy was missing, counts here.
    pub escaped_bodies: u64,
}

/// A body within this distance of its single-world copy before a flip (and [`TRACKED_MPS`] of
/// its velocity) is judged for a jump at the flip, m.
pub const TRACKED_M: f64 = 0.01;

/// A body within this speed of its single-world copy's velocity before a flip (and
/// [`TRACKED_M`] of its position) is judged for a jump at the flip, m/s: a body in a pile
/// whose velocity is already that far off meets its neighbours otherwise over the flip tick
/// whoever owns it (measured on `grid`: a ball 1 cm and 0.11 m/s off before its flip "jumped"
/// 0.08 m/s, as it would have without one).
pub const TRACKED_MPS: f64 = 0.05;

/// A body this far from its single-world copy marks the onset of an error, m.
pub const ONSET_M: f64 = 0.02;

/// Accumulates the comparison over a run.
pub struct Comparison {
    tick: u64,
    pos_sq: f64,
    rot_sq: f64,
    samples: u64,
    acc: Accuracy,
    momentum_err_sum: f64,
    momentum_ref_sum: f64,
    momentum_drift_sum: f64,
    /// The reference's total momentum at the first tick observed.
    momentum_start: Option<[f64; 3]>,
    reference_hits: BTreeMap<(EntityId, EntityId), u64>,
    split_hits: BTreeMap<(EntityId, EntityId), u64>,
    /// Last split sighting: owner, state; and the reference state then.
    last: IdMap<EntityId, (ClusterId, EntityState, EntityState)>,
    /// Where a body has escaped the world (see [`Accuracy::escaped_bodies`]).
    bounds: WorldBounds,
    /// Bodies that escaped.
    escaped: HashSet<EntityId>,
    /// The body with the largest position error so far, and when.
    worst: Option<(EntityId, u64)>,
    /// The body with the largest judged hand-off jump so far, and the tick of its flip.
    worst_jump: Option<(EntityId, u64)>,
    /// The entity whose every tick is printed (see [`Comparison::trace`]).
    traced: Option<EntityId>,
    /// Where the bodies already off track at their last sighting may be over the next tick.
    off_track: OffTrack,
}

/// Boxes round the bodies already off track (beyond [`TRACKED_M`] or [`TRACKED_MPS`] of their
/// single-world copies): each covers both copies swept over two ticks (a flip with a tick in
/// transit spans two) and grown by [`NEAR_M`]. A
/// tracked body that may meet one of them is not judged for a jump: what it meets is elsewhere
/// in the split run, so its motion departs for reasons its own hand-off has no part in
/// (measured on `open/corner`: a shot handed diagonally hit a crate 0.57 m from where one world
/// had it, 0.5 m further on, and "jumped" 0.71 m).
struct OffTrack {
    /// Two ticks, s: how far the boxes are swept.
    sweep_s: f32,
    grid: BoxGrid,
    boxes: Vec<Region>,
}

/// How near a body must come to one off track to count as meeting it, m.
const NEAR_M: f32 = 0.05;

impl OffTrack {
    fn new(dt: f32) -> Self {
        Self {
            sweep_s: 2.0 * dt,
            grid: BoxGrid::new(1.0),
            boxes: Vec::new(),
        }
    }

    /// The box round a body's two copies over the next two ticks.
    fn reach(&self, state: &EntityState, truth: &EntityState) -> Region {
        let split = seam_proxy::extent(state, self.sweep_s);
        split
            .union(&seam_proxy::extent(truth, self.sweep_s))
            .grown(NEAR_M)
    }

    /// Files every body of `last` (last sightings) that is off track.
    fn mark(&mut self, last: &IdMap<EntityId, (ClusterId, EntityState, EntityState)>) {
        self.grid.clear();
        self.boxes.clear();
        for (_, state, truth) in last.values() {
            if !tracked(state, truth) {
                let reach = self.reach(state, truth);
                self.grid
                    .insert(self.boxes.len() as u32, reach.min, reach.max);
                self.boxes.push(reach);
            }
        }
        self.grid.seal();
    }

    /// Whether a body with these copies may meet one off track over the next two ticks.
    fn near(&self, state: &EntityState, truth: &EntityState) -> bool {
        let reach = self.reach(state, truth);
        self.grid.any(reach.min, reach.max, |i| {
            self.boxes[i as usize].overlaps(&reach)
        })
    }
}

/// Whether a body is within [`TRACKED_M`] and [`TRACKED_MPS`] of its single-world copy.
fn tracked(state: &EntityState, truth: &EntityState) -> bool {
    distance(state.position, truth.position) <= TRACKED_M
        && distance(state.linvel, truth.linvel) <= TRACKED_MPS
}

/// What a body must stay within: above the lowest static surface, inside a region.
struct WorldBounds {
    floor: Option<f32>,
    regions: Vec<Region>,
}

impl WorldBounds {
    fn escaped(&self, p: [f32; 3]) -> bool {
        self.floor.is_some_and(|floor| p[1] < floor)
            || !self.regions.iter().any(|r| r.contains_within(p, 0.0))
    }
}

/// An entity's mass, kg; a catalog shape's volume from `catalog`.
fn mass(state: &EntityState, catalog: &ShapeCatalog) -> f64 {
    use std::f64::consts::PI;
    let volume = match state.body.shape {
        Shape::Catalog { id, .. } => f64::from(catalog.volume(id).unwrap_or(0.0)),
        Shape::Ball { radius } => 4.0 / 3.0 * PI * f64::from(radius).powi(3),
        Shape::Cuboid {
            half_extents: [x, y, z],
        } => 8.0 * f64::from(x * y * z),
        Shape::Capsule {
            half_height,
            radius,
        } => {
            let r = f64::from(radius);
            PI * r * r * (2.0 * f64::from(half_height) + 4.0 / 3.0 * r)
        }
    };
    f64::from(state.body.density) * volume
}

fn distance(a: [f32; 3], b: [f32; 3]) -> f64 {
    (0..3)
        .map(|k| f64::from(a[k] - b[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Angle between two orientations, degrees.
fn angle_deg(a: [f32; 4], b: [f32; 4]) -> f64 {
    let dot: f64 = (0..4).map(|k| f64::from(a[k]) * f64::from(b[k])).sum();
    2.0 * dot.abs().min(1.0).acos().to_degrees()
}

/// The bodies a world moves itself, with their states: dynamic ones, and kinematic ones its
/// game code moves (a platform must be where the single world has it, and owned once, too).
fn simulated(pod: &Pod) -> impl Iterator<Item = EntityState> + '_ {
    let sim = pod.cluster().sim();
    let me = pod.cluster().id();
    sim.entities()
        .filter(move |(_, info)| {
            info.owner == me
                && matches!(
                    info.role,
                    BodyRole::Dynamic | BodyRole::KinematicVelocityBased
                )
        })
        .filter_map(|(id, _)| sim.state(id))
}

fn record_hits(
    pod: &Pod,
    projectiles: &HashSet<EntityId>,
    tick: u64,
    hits: &mut BTreeMap<(EntityId, EntityId), u64>,
) {
    for contact in pod.cluster().sim().contacts() {
        // A hit is a projectile meeting something that is not a projectile: two shots meeting
        // (ricochets piling up) are not what a shooter aims at.
        if contact.started && (projectiles.contains(&contact.a) != projectiles.contains(&contact.b))
        {
            let pair = (contact.a.min(contact.b), contact.a.max(contact.b));
            hits.entry(pair).or_insert(tick);
        }
    }
}

impl Comparison {
    /// A comparison of `scene` split against its single-world `reference`, which has just been
    /// built (its static bodies give the lowest surface).
    pub fn new(scene: &Scene, reference: &Pod) -> Self {
        let sim = reference.cluster().sim();
        let floor = sim
            .entities()
            .filter(|(_, info)| info.role == BodyRole::Fixed)
            .filter_map(|(id, _)| sim.state(id))
            .map(|state| seam_proxy::extent(&state, 0.0).max[1])
            .min_by(f32::total_cmp);
        let regions = scene
            .clusters
            .iter()
            .map(|c| Region {
                min: c.region.min,
                max: c.region.max,
            })
            .collect();
        Self {
            bounds: WorldBounds { floor, regions },
            escaped: HashSet::new(),
            worst: None,
            worst_jump: None,
            tick: 0,
            pos_sq: 0.0,
            rot_sq: 0.0,
            samples: 0,
            acc: Accuracy::default(),
            momentum_err_sum: 0.0,
            momentum_ref_sum: 0.0,
            momentum_drift_sum: 0.0,
            momentum_start: None,
            reference_hits: BTreeMap::new(),
            split_hits: BTreeMap::new(),
            last: IdMap::default(),
            traced: None,
            off_track: OffTrack::new(scene.dt),
        }
    }

    /// Prints, on stderr after each tick, where the entity `name` (`name#i` for a grid copy)
    /// is in the split run and in the single world, who simulates it, and how far apart the
    /// two are: where an error comes from. An error if the reference has no such entity.
    pub fn trace(&mut self, reference: &Pod, name: &str) -> BenchResult<()> {
        let sim = reference.cluster().sim();
        let id = sim
            .entities()
            .map(|(id, _)| id)
            .find(|&id| reference.entity_name(id) == name)
            .or_else(|| {
                name.starts_with("shot:")
                    .then(|| reference.entity_id(name))
                    .flatten()
            })
            .ok_or_else(|| {
                BenchError::flag(
                    "--trace",
                    format!(
                        "no entity {name:?} in the scene (a grid copy is `name#i`, a \
                         projectile `shot:E.S`: event E, counted from 0, its shot S)"
                    ),
                )
            })?;
        self.traced = Some(id);
        crate::console::line(
            "tick owner: split position m, velocity m/s | one world position, velocity | apart m",
        );
        Ok(())
    }

    fn print_traced(&self, tick: u64, split: Option<(&str, &EntityState)>, truth: &EntityState) {
        let v = |a: [f32; 3]| format!("({:7.2} {:6.2} {:7.2})", a[0], a[1], a[2]);
        let one = format!("{} {}", v(truth.position), v(truth.linvel));
        match split {
            Some((owner, state)) => crate::console::line(&format!(
                "{tick:5} {owner}: {} {} | {one} | {:.3}",
                v(state.position),
                v(state.linvel),
                distance(state.position, truth.position)
            )),
            None => crate::console::line(&format!(
                "{tick:5} nobody simulates it (in transit or lost) | {one}"
            )),
        }
    }

    /// Compares the worlds after one tick of each.
    pub fn observe(&mut self, reference: &Pod, pods: &[Pod]) {
        self.tick += 1;
        self.off_track.mark(&self.last);
        let tick = self.tick;
        let catalog = reference.cluster().sim().shapes();
        let truth: IdMap<EntityId, EntityState> = simulated(reference).map(|s| (s.id, s)).collect();
        let projectiles: HashSet<EntityId> = reference.projectiles().iter().copied().collect();
        let mut seen: IdMap<EntityId, ClusterId> = IdMap::default();
        let mut traced_seen = false;
        let (mut p_split, mut p_ref) = ([0.0f64; 3], [0.0f64; 3]);
        for pod in pods {
            for state in simulated(pod) {
                let owner = pod.cluster().id();
                if seen.insert(state.id, owner).is_some() {
                    self.acc.duplicate_owner_ticks += 1;
                    continue;
                }
                let m = mass(&state, catalog);
                for (p, v) in p_split.iter_mut().zip(state.linvel) {
                    *p += m * f64::from(v);
                }
                let Some(truth) = truth.get(&state.id) else {
                    continue;
                };
                if self.traced == Some(state.id) {
                    traced_seen = true;
                    self.print_traced(tick, Some((pod.name(), &state)), truth);
                }
                self.note_handoff(tick, owner, &state, truth);
                self.last.insert(state.id, (owner, state, *truth));
                // Projectiles count for hand-offs, not for position error: once one hits in one
                // run and not in the other, it flies hundreds of metres apart, and the hit
                // metrics already count that.
                if projectiles.contains(&state.id) {
                    continue;
                }
                self.note_error(tick, &state, truth);
            }
        }
        let mut speed_sum = 0.0;
        for state in truth.values() {
            let m = mass(state, catalog);
            for (p, v) in p_ref.iter_mut().zip(state.linvel) {
                *p += m * f64::from(v);
            }
            speed_sum += m * distance(state.linvel, [0.0; 3]);
            if !seen.contains_key(&state.id) {
                // In transit, its momentum is the one its hand-off carries: what the old
                // owner's proxy of it reads.
                let carried = pods.iter().find_map(|p| p.cluster().sim().state(state.id));
                if let Some(carried) = carried {
                    self.acc.in_transit_ticks += 1;
                    for (p, v) in p_split.iter_mut().zip(carried.linvel) {
                        *p += m * f64::from(v);
                    }
                } else {
                    self.acc.missing_entity_ticks += 1;
                }
            }
        }
        if let Some(id) = self.traced
            && !traced_seen
            && let Some(truth) = truth.get(&id)
        {
            self.print_traced(tick, None, truth);
        }
        // A push routed this tick reaches its owner's body in the owner's next tick: until
        // then its momentum is in flight, as a body in transit carries its own.
        for (id, push) in pods.iter().flat_map(|p| p.routed_pushes()) {
            if truth.contains_key(id) {
                for (p, j) in p_split.iter_mut().zip(push) {
                    *p += f64::from(*j);
                }
            }
        }
        self.note_momentum(p_split, p_ref, speed_sum);

        record_hits(reference, &projectiles, tick, &mut self.reference_hits);
        for pod in pods {
            record_hits(pod, &projectiles, tick, &mut self.split_hits);
        }
    }

    /// An authority flip of `state` to `owner` since the last tick: counted, and how far the
    /// new owner's motion over the tick departs from the reference's. A tracked body's tick
    /// without a flip is measured the same way, for [`Accuracy::step_jump_position_m`].
    fn note_handoff(
        &mut self,
        tick: u64,
        owner: ClusterId,
        state: &EntityState,
        truth: &EntityState,
    ) {
        let Some((was, before, truth_before)) = self.last.get(&state.id) else {
            return;
        };
        let flip = *was != owner;
        let tracked = tracked(before, truth_before) && !self.off_track.near(before, truth_before);
        if flip {
            self.acc.handoffs += 1;
            if !tracked {
                self.acc.handoffs_untracked += 1;
            }
        }
        if !tracked {
            return;
        }
        let moved = sub(state.position, before.position);
        let moved_truth = sub(truth.position, truth_before.position);
        let sped = sub(state.linvel, before.linvel);
        let sped_truth = sub(truth.linvel, truth_before.linvel);
        let (jump, sped_off) = (distance(moved, moved_truth), distance(sped, sped_truth));
        let acc = &mut self.acc;
        if !flip {
            acc.step_jump_position_m = acc.step_jump_position_m.max(jump);
            acc.step_jump_velocity_mps = acc.step_jump_velocity_mps.max(sped_off);
            return;
        }
        if jump > acc.handoff_jump_position_m {
            self.worst_jump = Some((state.id, tick));
        }
        acc.handoff_jump_position_m = acc.handoff_jump_position_m.max(jump);
        acc.handoff_jump_velocity_mps = acc.handoff_jump_velocity_mps.max(sped_off);
    }

    /// One body's error against the reference this tick.
    fn note_error(&mut self, tick: u64, state: &EntityState, truth: &EntityState) {
        if self.bounds.escaped(state.position) && !self.bounds.escaped(truth.position) {
            self.escaped.insert(state.id);
        }
        let error = distance(state.position, truth.position);
        let turn = angle_deg(state.rotation, truth.rotation);
        self.pos_sq += error * error;
        self.rot_sq += turn * turn;
        self.samples += 1;
        if error >= ONSET_M && self.acc.onset_tick.is_none() {
            self.acc.onset_tick = Some(tick);
        }
        if error > self.acc.position_max_m {
            self.acc.position_max_m = error;
            self.worst = Some((state.id, tick));
        }
        self.acc.rotation_max_deg = self.acc.rotation_max_deg.max(turn);
    }

    /// The tick's momentum, split (`p_split`) against the reference (`p_ref`, its summed
    /// mass-weighted speed `speed_sum`).
    fn note_momentum(&mut self, p_split: [f64; 3], p_ref: [f64; 3], speed_sum: f64) {
        let error = (0..3)
            .map(|k| (p_split[k] - p_ref[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        self.acc.momentum_error_max = self.acc.momentum_error_max.max(error);
        self.momentum_err_sum += error;
        self.momentum_ref_sum += speed_sum;
        let start = *self.momentum_start.get_or_insert(p_ref);
        self.momentum_drift_sum += (0..3)
            .map(|k| (p_ref[k] - start[k]).powi(2))
            .sum::<f64>()
            .sqrt();
    }

    /// The accuracy over everything observed; `name` names an entity of the scene.
    pub fn finish(mut self, name: impl Fn(EntityId) -> String) -> Accuracy {
        self.acc.worst_body = self.worst.map(|(id, tick)| (name(id), tick));
        self.acc.worst_handoff = self.worst_jump.map(|(id, tick)| (name(id), tick));
        let n = self.samples.max(1) as f64;
        self.acc.position_rms_m = (self.pos_sq / n).sqrt();
        self.acc.rotation_rms_deg = (self.rot_sq / n).sqrt();
        (self.acc.momentum_error_rel, self.acc.momentum_drift_rel) = if self.momentum_ref_sum > 0.0
        {
            (
                self.momentum_err_sum / self.momentum_ref_sum,
                self.momentum_drift_sum / self.momentum_ref_sum,
            )
        } else {
            (0.0, 0.0)
        };
        let mut matched = 0u64;
        let mut offset_sum = 0u64;
        for (pair, tick) in &self.reference_hits {
            if let Some(split_tick) = self.split_hits.get(pair) {
                matched += 1;
                offset_sum += tick.abs_diff(*split_tick);
            }
        }
        let a = &mut self.acc;
        a.escaped_bodies = self.escaped.len() as u64;
        a.hits_reference = self.reference_hits.len() as u64;
        a.hits_split = self.split_hits.len() as u64;
        a.hits_matched = matched;
        a.hit_recall = (a.hits_reference > 0).then(|| matched as f64 / a.hits_reference as f64);
        a.hit_precision = (a.hits_split > 0).then(|| matched as f64 / a.hits_split as f64);
        a.hit_tick_offset_mean = if matched == 0 {
            0.0
        } else {
            offset_sum as f64 / matched as f64
        };
        self.acc
    }
}
