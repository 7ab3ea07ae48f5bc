//! The main job judged: a `seam run` of free-running pods against one world of the same scene,
//! run in this process for as many ticks once the pods are done, beside that world's noise
//! floor (see [`super::FloorRun`]).
//!
//! Free-running pods report where their bodies ended, what their projectiles hit and every
//! authority flip, so that is what is judged: final positions, hits, hand-off jumps, bodies
//! owned twice or by nobody. The onset is not known (no pod reports every tick).

use serde::Serialize;

use super::{Accuracy, FloorWorld, TrialSettings, beyond_floor};
use crate::document::Document;
use crate::error::{BenchResult, Context};
use crate::node::NodeReport;
use crate::run::{RunPlan, RunReport};

/// How far a run's pods ended from one world, and how far one world ends from itself.
#[derive(Debug, Clone, Serialize)]
pub struct AgainstOneWorld {
    /// The pods against one world.
    pub accuracy: Accuracy,
    /// One world again, bodies inserted in reverse order and each dynamic one moved
    /// [`super::PERTURBATION_M`], against the first: the noise floor, the farthest figures of
    /// [`super::FLOOR_WORLDS`] such worlds.
    pub floor: Accuracy,
    /// Each of those worlds' position error.
    pub floor_worlds: Vec<FloorWorld>,
    /// The figures that miss the floor's targets ([`beyond_floor`]); empty at the floor.
    pub beyond_floor: Vec<String>,
}

impl AgainstOneWorld {
    /// Judges the pods' reports `nodes` of the run `plan` made.
    pub fn judge(plan: &RunPlan, nodes: &[NodeReport]) -> BenchResult<Self> {
        let scene = crate::scene::load(&plan.scene)?
            .stacked(plan.layers)
            .context("the scene judged")?;
        let ticks = plan.ticks.unwrap_or(scene.ticks);
        let settings = TrialSettings {
            proxy_mode: plan.proxy_mode.into(),
            authority: plan.authority,
            replication_interval: plan.replication_interval,
            coupling: plan.coupling,
            exchange: plan.exchange,
            quantize: plan.quantize,
            keyframe_ticks: plan.keyframe_ticks,
            ticks: Some(ticks),
            ..TrialSettings::default()
        };
        let (accuracy, floor) =
            super::free::judge_pods(&scene, &settings, &plan.run_id, ticks, nodes)?;
        Ok(Self {
            beyond_floor: beyond_floor(&accuracy, &floor.farthest),
            accuracy,
            floor: floor.farthest,
            floor_worlds: floor.worlds,
        })
    }

    /// The judgement as lines of a report.
    pub fn document(&self) -> Document {
        let (a, f) = (&self.accuracy, &self.floor);
        let mut doc = Document::new();
        doc.line(
            "Against one world (the same scene and ticks run here once the pods were done; \
             where bodies ended):",
        );
        doc.line(format!(
            "  position error   RMS {:.4} m, max {:.4} m{}",
            a.position_rms_m,
            a.position_max_m,
            a.worst_body
                .as_ref()
                .map_or(String::new(), |(name, _)| format!(" (largest: {name})"))
        ));
        doc.line(format!(
            "  noise floor      RMS {:.4} m, max {:.4} m: {}",
            f.position_rms_m,
            f.position_max_m,
            super::floor_words(&self.floor_worlds)
        ));
        doc.line(format!(
            "  against it       {}",
            if self.beyond_floor.is_empty() {
                "at the floor (RMS ≤ max(1.5 × floor, 1 cm), max ≤ max(1.5 × floor, 5 cm), \
                 hand-off jump ≤ max(1.5 × floor's one-tick departure, 1 cm and 0.05 m/s))"
                    .to_owned()
            } else {
                format!("beyond it: {}", self.beyond_floor.join("; "))
            }
        ));
        doc.line(format!(
            "  projectile hits  {} in one world, {} here, {} the same (recall {}, precision {})",
            a.hits_reference,
            a.hits_split,
            a.hits_matched,
            super::ratio(a.hit_recall),
            super::ratio(a.hit_precision)
        ));
        doc.line(format!(
            "  hand-offs        {} ({} untracked), largest jump {:.4} m, {:.3} m/s",
            a.handoffs,
            a.handoffs_untracked,
            a.handoff_jump_position_m,
            a.handoff_jump_velocity_mps
        ));
        doc
    }
}

/// A `seam run`'s report with its judgement against one world (none when not asked for).
#[derive(Debug, Serialize)]
pub struct JudgedRun {
    /// The run.
    #[serde(flatten)]
    pub run: RunReport,
    /// Its pods against one world.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub against_one_world: Option<AgainstOneWorld>,
}

/// What `seam run` prints: the run's report, then its judgement.
pub fn judged_document(judged: &JudgedRun) -> Document {
    let mut doc = crate::run::document(&judged.run);
    if let Some(against) = &judged.against_one_world {
        doc.line("");
        doc.append(against.document());
    }
    doc
}
