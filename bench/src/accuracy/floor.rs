//! The noise floor: how far a second single world, changed at round-off scale, drifts from
//! the first on the same scene.
//!
//! A split world is never bit-identical to one world (sums run in another order, proxies
//! stand in for bodies), so on a chaotic scene — volleys into piles, balls drifting into each
//! other — it ends metres off for the same reason a perturbed single world does. The floor
//! measures that: [`FLOOR_WORLDS`] single worlds, each with every dynamic body of the scene
//! moved [`PERTURBATION_M`] in a direction of its own (see [`crate::pod::perturbed`]) and
//! every body inserted in reverse order, run beside the single world tick for tick and judged
//! with the same metrics ([`Comparison`]). The farthest of them is the floor ([`Floor::of`]).
//!
//! Both changes are ones the split makes itself. Its worlds insert bodies in another order
//! (hand-offs, proxies), and Rapier's solver, a fixed number of iterations over contacts in
//! insertion order, then ends a step elsewhere where it had not converged: on `platform` (a
//! stack riding a platform that turns round) the single world with bodies inserted in reverse
//! order ends 2.7 cm RMS (7.6 cm max) from the first and departs by 2 cm at tick 403, where
//! moving every body 1 µm alone changes nothing (0.0000 m); the split, with every body
//! handed along the platform's way, 2.8 cm RMS (7.5 cm max), departing at tick 398. A
//! split error at the floor is chaos; one far above it, or one whose onset comes much
//! earlier, is the split's.

use std::collections::HashMap;
use std::sync::Mutex;

use serde::Serialize;

use seam_sim::wire::{EntityId, IdMap};

use super::Accuracy;
use super::compare::Comparison;
use crate::error::{BenchResult, Context};
use crate::pod::{Pod, PodSettings};
use crate::scene::Scene;

/// How far the floor's single world moves each dynamic body, m: 1 µm, about one f32 step at
/// 10 m from the origin — round-off scale, as the split's own differences are (sums in another
/// order). Measured beside 10 µm on the bundled scenes: the floors agree within 20 % where
/// the scene is chaotic (`crossfire` 2.55 against 2.66 m RMS, `stacks` 0.057 against 0.051 m),
/// and 10 µm lifts the floor of a calm scene above round-off (`seam-stack` 0.0015 against
/// 0.0003 m, reaching 2 cm at tick 419 where 1 µm never does).
pub const PERTURBATION_M: f32 = 1.0e-6;

/// How many perturbed single worlds a floor runs, each body moved in a direction drawn afresh
/// for each. One is not enough: on a scene where a contact starts at round-off distance, the
/// direction alone decides how far the world drifts (`four-corners`, these three worlds:
/// 0.0199, 0.0002 and 0.0226 m RMS, the second never 2 cm off, the others from tick 2;
/// `stacks` 0.052, 0.133 and 0.036 m).
pub const FLOOR_WORLDS: u32 = 3;

/// What the floor's positions are taken over, as for the split run it stands beside.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Basis {
    /// Every tick (lock-step trials).
    EveryTick,
    /// The final tick only (free-running pods report where their bodies ended).
    FinalTick,
}

/// Floors measured in this process, by scene (as the trial runs it), ids and basis: every
/// trial of one scene has the same single world, so a sweep measures its floor once.
static MEASURED: Mutex<Option<HashMap<String, Floor>>> = Mutex::new(None);

fn measured(key: &str) -> Option<Floor> {
    let floors = MEASURED.lock().unwrap_or_else(|e| e.into_inner());
    floors.as_ref().and_then(|f| f.get(key).cloned())
}

fn remember(key: String, floor: &Floor) {
    let mut floors = MEASURED.lock().unwrap_or_else(|e| e.into_inner());
    floors.get_or_insert_default().insert(key, floor.clone());
}

/// The floor of one trial, run beside its single world.
pub struct FloorRun {
    key: String,
    basis: Basis,
    /// The perturbed worlds, each with its comparison with the single world; empty when this
    /// process has measured the floor already.
    worlds: Vec<(Pod, Comparison)>,
}

impl FloorRun {
    /// The floor of `scene` beside `reference` (just built, not ticked), the perturbed world
    /// built with `settings` (a transport of its own, the reference's run id).
    pub fn start(
        scene: &Scene,
        reference: &Pod,
        settings: &PodSettings,
        basis: Basis,
    ) -> BenchResult<Self> {
        let key = format!("{scene:?} {} {basis:?}", settings.run_id);
        let mut worlds = Vec::new();
        if measured(&key).is_none() {
            for world in 0..FLOOR_WORLDS {
                let perturbed = Pod::new(
                    scene,
                    &crate::pod::Part::Reference,
                    &PodSettings {
                        transport: format!("{}w{world}_", settings.transport),
                        perturbation_m: PERTURBATION_M,
                        perturbation_world: world,
                        ..settings.clone()
                    },
                )
                .context("noise floor")?;
                worlds.push((perturbed, Comparison::new(scene, reference)));
            }
        }
        Ok(Self { key, basis, worlds })
    }

    /// One tick of the perturbed world, after one of `reference`.
    pub fn observe(&mut self, reference: &Pod) -> BenchResult<()> {
        for (perturbed, comparison) in &mut self.worlds {
            perturbed.tick().context("noise floor")?;
            comparison.observe(reference, std::slice::from_ref(perturbed));
        }
        Ok(())
    }

    /// The floor: each perturbed world judged against `reference` as a split run is, and
    /// the farthest figures of them all.
    pub fn finish(self, reference: &Pod) -> Floor {
        if self.worlds.is_empty() {
            return measured(&self.key).unwrap_or_default();
        }
        let truth: IdMap<EntityId, [f32; 3]> =
            reference.simulated_positions().into_iter().collect();
        let worlds: Vec<Accuracy> = self
            .worlds
            .into_iter()
            .map(|(perturbed, comparison)| {
                let mut world = comparison.finish(|id| reference.entity_name(id));
                if self.basis == Basis::FinalTick {
                    let ended = perturbed.simulated_positions();
                    (world.position_rms_m, world.position_max_m) = final_errors(&ended, &truth);
                }
                world
            })
            .collect();
        let floor = Floor::of(worlds);
        remember(self.key, &floor);
        floor
    }
}

/// A trial's noise floor: [`FLOOR_WORLDS`] perturbed single worlds against the first.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Floor {
    /// The farthest any of them went, figure by figure (see [`Floor::of`]). A split run is
    /// judged against these.
    pub farthest: Accuracy,
    /// Each world's own figures.
    pub worlds: Vec<FloorWorld>,
}

/// One perturbed world's distance from the single world.
#[derive(Debug, Clone, Default, Serialize)]
pub struct FloorWorld {
    /// Position error, RMS, m.
    pub position_rms_m: f64,
    /// Largest position error, m.
    pub position_max_m: f64,
    /// The first tick a body was [`super::ONSET_M`] off (`None`: never; not known on a
    /// final-tick basis).
    pub onset_tick: Option<u64>,
}

impl Floor {
    /// The floor of `worlds`: the world with the largest position RMS (its worst body, hits
    /// and momentum), with the largest max, rotation and one-tick departure of any, and the
    /// earliest onset (never only where none departs). Chaos alone reached each of these in
    /// one of the worlds; a split run that is farther on a figure than 1.5 × the farthest is
    /// beyond what chaos explains.
    pub fn of(worlds: Vec<Accuracy>) -> Self {
        let each = worlds
            .iter()
            .map(|w| FloorWorld {
                position_rms_m: w.position_rms_m,
                position_max_m: w.position_max_m,
                onset_tick: w.onset_tick,
            })
            .collect();
        let fold = |f: fn(&Accuracy) -> f64| worlds.iter().map(f).fold(0.0, f64::max);
        let (max, rotation, jump_m, jump_mps) = (
            fold(|w| w.position_max_m),
            fold(|w| w.rotation_max_deg),
            fold(|w| w.step_jump_position_m),
            fold(|w| w.step_jump_velocity_mps),
        );
        let onset = worlds.iter().filter_map(|w| w.onset_tick).min();
        let mut farthest = worlds
            .into_iter()
            .max_by(|a, b| a.position_rms_m.total_cmp(&b.position_rms_m))
            .unwrap_or_default();
        farthest.position_max_m = max;
        farthest.rotation_max_deg = rotation;
        farthest.step_jump_position_m = jump_m;
        farthest.step_jump_velocity_mps = jump_mps;
        farthest.onset_tick = onset;
        Self {
            farthest,
            worlds: each,
        }
    }
}

/// What a floor is, in words, with each world's position RMS and max (`worlds`): "the farthest
/// of 3 single worlds again, …".
pub fn floor_words(worlds: &[FloorWorld]) -> String {
    let each = worlds
        .iter()
        .map(|w| format!("{:.4}/{:.4}", w.position_rms_m, w.position_max_m))
        .collect::<Vec<_>>()
        .join(", ");
    format!(
        "the farthest of {} single worlds again, bodies inserted in reverse order and each \
         dynamic one moved {} µm in a direction of its own (each world's RMS/max: {each} m)",
        worlds.len(),
        PERTURBATION_M * 1e6
    )
}

/// RMS and largest distance of `ended` from `truth` (bodies in both), m.
pub(super) fn final_errors(
    ended: &[(EntityId, [f32; 3])],
    truth: &IdMap<EntityId, [f32; 3]>,
) -> (f64, f64) {
    let (mut squares, mut samples, mut max) = (0.0f64, 0u64, 0.0f64);
    for (id, position) in ended {
        if let Some(t) = truth.get(id) {
            let error = (0..3)
                .map(|k| f64::from(position[k] - t[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            squares += error * error;
            samples += 1;
            max = max.max(error);
        }
    }
    ((squares / samples.max(1) as f64).sqrt(), max)
}

/// How far a split run may be from one world, against its noise floor `floor`: position RMS at
/// most max(1.5 × the floor's, 1 cm), the largest error at most max(1.5 × the floor's, 5 cm),
/// the onset no earlier than 0.8 × the floor's (never, where the floor never departs), and the
/// largest hand-off jump at most max(1.5 × the floor's largest one-tick departure of a tracked
/// body, 1 cm) in position and max(1.5 × that, 0.05 m/s) in velocity (a flip is a tick on which
/// a body changes worlds; the floor's run has none, so its ordinary ticks are what chaos gives a
/// body tracked as closely). Returns the figures of `split` that miss, in words; none when it is
/// at the floor.
pub fn beyond_floor(split: &Accuracy, floor: &Accuracy) -> Vec<String> {
    let mut misses = Vec::new();
    let rms = (1.5 * floor.position_rms_m).max(0.01);
    if split.position_rms_m > rms {
        misses.push(format!(
            "position RMS {:.4} m > {rms:.4} m",
            split.position_rms_m
        ));
    }
    let max = (1.5 * floor.position_max_m).max(0.05);
    if split.position_max_m > max {
        misses.push(format!("max {:.4} m > {max:.4} m", split.position_max_m));
    }
    match (split.onset_tick, floor.onset_tick) {
        (Some(at), Some(floor)) if (at as f64) < 0.8 * floor as f64 => {
            misses.push(format!("onset tick {at} < 0.8 × the floor's {floor}"))
        }
        (Some(at), None) => misses.push(format!("onset tick {at}, the floor's never")),
        _ => {}
    }
    let jump_m = (1.5 * floor.step_jump_position_m).max(0.01);
    if split.handoff_jump_position_m > jump_m {
        misses.push(format!(
            "hand-off jump {:.4} m > {jump_m:.4} m",
            split.handoff_jump_position_m
        ));
    }
    let jump_mps = (1.5 * floor.step_jump_velocity_mps).max(0.05);
    if split.handoff_jump_velocity_mps > jump_mps {
        misses.push(format!(
            "hand-off jump {:.3} m/s > {jump_mps:.3} m/s",
            split.handoff_jump_velocity_mps
        ));
    }
    misses
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pod::Part;

    /// The floor is the farthest any of its worlds went, figure by figure: one world's calm
    /// onset does not hide another's departure, nor a small RMS another's large max.
    #[test]
    fn a_floor_takes_each_figure_from_the_world_farthest_on_it() {
        let world = |rms: f64, max: f64, onset: Option<u64>, jump: f64| Accuracy {
            position_rms_m: rms,
            position_max_m: max,
            onset_tick: onset,
            step_jump_velocity_mps: jump,
            ..Accuracy::default()
        };
        let floor = Floor::of(vec![
            world(0.02, 0.04, Some(2), 0.03),
            world(0.0002, 0.0007, None, 0.5),
            world(0.03, 0.03, Some(4), 0.1),
        ]);
        let f = &floor.farthest;
        assert_eq!(
            (f.position_rms_m, f.position_max_m, f.onset_tick),
            (0.03, 0.04, Some(2))
        );
        assert_eq!(f.step_jump_velocity_mps, 0.5);
        assert_eq!(floor.worlds.len(), 3);
        let calm = Floor::of(vec![world(0.0, 0.0, None, 0.0); 2]);
        assert_eq!(calm.farthest.onset_tick, None);
    }

    /// A scene's floor is the same whatever its run is named: each body's direction comes
    /// from its name in the scene, not from its id (drawn from the run's name). Before, each
    /// free-running run stood beside a floor of its own (`stacks` 0.03 to 0.36 m).
    #[test]
    fn a_scenes_floor_is_the_same_whatever_the_run_is_named() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/stacks.toml");
        let scene = crate::scene::load(&path).expect("stacks");
        let floor = |run: &str| {
            let prefix = format!("local?prefix=seam_floor_test_{}_{run}_", std::process::id());
            let settings = PodSettings::new(format!("{prefix}floor_"), run);
            let mut reference = Pod::new(
                &scene,
                &Part::Reference,
                &PodSettings::new(format!("{prefix}ref_"), run),
            )
            .expect("reference");
            let mut floor =
                FloorRun::start(&scene, &reference, &settings, Basis::FinalTick).expect("floor");
            for _ in 0..320 {
                reference.tick().expect("reference");
                floor.observe(&reference).expect("floor");
            }
            floor.finish(&reference)
        };
        let (one, two) = (floor("one"), floor("two"));
        assert!(
            one.worlds.iter().all(|w| w.position_rms_m > 0.001),
            "stacks is chaotic: {:?}",
            one.worlds
        );
        assert_eq!(format!("{:?}", one.worlds), format!("{:?}", two.worlds));
    }

    /// A hand-off jump is judged beside the floor's largest one-tick departure of a tracked
    /// body, never under 1 cm and 0.05 m/s.
    #[test]
    fn a_hand_off_jump_is_judged_beside_the_floors_one_tick_departure() {
        let calm = Accuracy::default();
        let jumped = Accuracy {
            handoff_jump_position_m: 0.02,
            handoff_jump_velocity_mps: 0.3,
            ..Accuracy::default()
        };
        let misses = beyond_floor(&jumped, &calm);
        assert_eq!(misses.len(), 2, "{misses:?}");
        assert!(
            misses[0].starts_with("hand-off jump 0.0200 m"),
            "{misses:?}"
        );
        assert!(
            misses[1].starts_with("hand-off jump 0.300 m/s"),
            "{misses:?}"
        );
        let small = Accuracy {
            handoff_jump_position_m: 0.009,
            handoff_jump_velocity_mps: 0.04,
            ..Accuracy::default()
        };
        assert!(beyond_floor(&small, &calm).is_empty());
        let chaotic = Accuracy {
            step_jump_position_m: 0.05,
            step_jump_velocity_mps: 1.0,
            ..Accuracy::default()
        };
        assert!(beyond_floor(&jumped, &chaotic).is_empty());
    }
}
