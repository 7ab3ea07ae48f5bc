//! `seam network`: accuracy against the network between hosts.
//!
//! Each scene runs as free-running pods on two simulated hosts (see `seam run --hosts`), with
//! the second host's traffic to and from Redis delayed by each of the delays asked for (a relay
//! in front of Redis: this kernel has no `netem`, so the delay is simulated and labelled so),
//! and is compared with a single-world run as the sweep's transport axis does: projectile hit
//! recall, final position error, routed-op delay in ticks, hand-off jumps. Writes `network.csv` and one chart
//! per scene, `accuracy_vs_delay_SCENE.svg`/`.png`.
//!
//! Hand-off jumps are judged as `seam compare` judges them, from the states the pods record at
//! every authority flip (`seam node --track-flips`) against the single world's at the same
//! ticks: how far a body's motion from its old owner's last state to its new owner's first
//! departs from the single world's.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use plotters::prelude::*;

use crate::accuracy::{FreeRunning, TrialResult, TrialSettings, run_free_trial_on_hosts};
use crate::document::{Align::*, Document, Table};
use crate::error::{BenchError, BenchResult, Context};
use crate::relay::Delay;
use crate::run::HostsPlan;
use crate::scene::Scene;

/// One trial: a scene at one delay.
#[derive(Debug, Clone)]
pub struct DelayTrial {
    /// One-way delay added between host `b` and Redis, ms.
    pub delay_ms: f64,
    /// How the hosts were simulated.
    pub simulated_as: String,
    /// The comparison with the single world.
    pub result: TrialResult,
}

/// What `seam network` runs.
pub struct NetworkPlan {
    /// Scenes (file, parsed).
    pub scenes: Vec<(PathBuf, Scene)>,
    /// One-way delays, ms.
    pub delays_ms: Vec<f64>,
    /// Jitter added to each delay, ms (uniform, order kept).
    pub jitter_ms: f64,
    /// Ticks per second of the pods.
    pub rate: f64,
    /// Stagger the pods over the period instead of ticking them in phase.
    pub stagger: bool,
    /// Routed ops exchanged before the step (see `seam_proxy::ClusterConfig::exchange`).
    pub exchange: bool,
    /// The Redis server between hosts.
    pub redis: String,
    /// The command that starts a pod (`[seam, "node"]`).
    pub node_command: Vec<std::ffi::OsString>,
}

/// Runs every scene at every delay; `progress` hears each trial as it ends.
pub fn run(
    plan: &NetworkPlan,
    mut progress: impl FnMut(usize, usize, &str),
) -> BenchResult<Vec<DelayTrial>> {
    let total = plan.scenes.len() * plan.delays_ms.len();
    let mut trials = Vec::new();
    for (path, scene) in &plan.scenes {
        for &delay_ms in &plan.delays_ms {
            let free = FreeRunning {
                rate: plan.rate,
                node_command: plan.node_command.clone(),
                stagger: plan.stagger,
                hosts: HostsPlan {
                    count: Some(2),
                    redis: plan.redis.clone(),
                    delay: Delay {
                        base: Duration::from_secs_f64(delay_ms / 1e3),
                        jitter: Duration::from_secs_f64(plan.jitter_ms / 1e3),
                    },
                    delayed_host: None,
                    namespaces: true,
                },
            };
            let run_id = crate::run::fresh_run_id();
            let (result, simulated_as) = run_free_trial_on_hosts(
                path,
                scene,
                &TrialSettings {
                    exchange: plan.exchange,
                    ..TrialSettings::default()
                },
                "shm",
                &free,
                &run_id,
            )
            .context(format!("{} at {delay_ms} ms", scene.name))?;
            trials.push(DelayTrial {
                delay_ms,
                simulated_as: simulated_as.unwrap_or_default(),
                result,
            });
            progress(
                trials.len(),
                total,
                &format!("{} at {delay_ms} ms", scene.name),
            );
        }
    }
    Ok(trials)
}

/// What `seam network` reports: a row per scene and delay.
pub fn document(trials: &[DelayTrial]) -> Document {
    let mut table = Table::new(&[
        ("scene", Left),
        ("delay ms", Right),
        ("hit recall", Right),
        ("hits", Right),
        ("pos RMS m", Right),
        ("pos max m", Right),
        ("floor RMS, max m", Right),
        ("ops sent/applied", Right),
        ("op p50 tick", Right),
        ("op max tick", Right),
        ("hand-offs", Right),
        ("jump m, m/s", Right),
    ]);
    for t in trials {
        let a = &t.result.accuracy;
        let c = &t.result.cost;
        table.row(vec![
            t.result.scene.clone(),
            t.delay_ms.to_string(),
            a.hit_recall.map_or("-".to_owned(), |r| format!("{r:.3}")),
            format!("{}/{}", a.hits_matched, a.hits_reference),
            format!("{:.4}", a.position_rms_m),
            format!("{:.3}", a.position_max_m),
            format!(
                "{:.4}, {:.3}",
                t.result.floor.position_rms_m, t.result.floor.position_max_m
            ),
            format!("{}/{}", c.ops_routed, c.ops),
            c.op_delay_p50_ticks.to_string(),
            c.op_delay_max_ticks.to_string(),
            format!("{} ({} untracked)", a.handoffs, a.handoffs_untracked),
            format!(
                "{:.4}, {:.3}",
                a.handoff_jump_position_m, a.handoff_jump_velocity_mps
            ),
        ]);
    }
    let mut doc = Document::new();
    doc.table(table);
    if let Some(t) = trials.first() {
        doc.line(format!("hosts simulated as {}", t.simulated_as));
    }
    doc
}

/// Writes `network.csv` and the charts into `out`; returns the files written.
pub fn write(trials: &[DelayTrial], out: &Path) -> BenchResult<Vec<PathBuf>> {
    std::fs::create_dir_all(out).map_err(|e| BenchError::io("create", out.display(), e))?;
    let csv = out.join("network.csv");
    let mut file =
        std::fs::File::create(&csv).map_err(|e| BenchError::io("write", csv.display(), e))?;
    let mut text = String::from(
        "scene,delay_ms,hit_recall,hits_matched,hits_reference,position_rms_m,position_max_m,floor_position_rms_m,floor_position_max_m,floor_onset_tick,ops_routed,ops,op_delay_p50_ticks,op_delay_max_ticks,op_transport_p50_us,tick_p99_us,handoffs,handoffs_untracked,handoff_jump_position_m,handoff_jump_velocity_mps,floor_step_jump_position_m,floor_step_jump_velocity_mps,at_floor,simulated_as\n",
    );
    for t in trials {
        let a = &t.result.accuracy;
        let c = &t.result.cost;
        text += &format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},\"{}\"\n",
            t.result.scene,
            t.delay_ms,
            a.hit_recall.map_or(String::new(), |r| r.to_string()),
            a.hits_matched,
            a.hits_reference,
            a.position_rms_m,
            a.position_max_m,
            t.result.floor.position_rms_m,
            t.result.floor.position_max_m,
            t.result
                .floor
                .onset_tick
                .map_or(String::new(), |t| t.to_string()),
            c.ops_routed,
            c.ops,
            c.op_delay_p50_ticks,
            c.op_delay_max_ticks,
            c.op_transport_p50_us,
            c.tick_p99_us,
            a.handoffs,
            a.handoffs_untracked,
            a.handoff_jump_position_m,
            a.handoff_jump_velocity_mps,
            t.result.floor.step_jump_position_m,
            t.result.floor.step_jump_velocity_mps,
            crate::accuracy::beyond_floor(a, &t.result.floor).is_empty(),
            t.simulated_as
        );
    }
    file.write_all(text.as_bytes())
        .map_err(|e| BenchError::io("write", csv.display(), e))?;
    let mut written = vec![csv];
    crate::sweep::chart_font()?;
    let mut scenes: Vec<&str> = trials.iter().map(|t| t.result.scene.as_str()).collect();
    scenes.dedup();
    for scene in scenes {
        let rows: Vec<&DelayTrial> = trials.iter().filter(|t| t.result.scene == scene).collect();
        let svg = out.join(format!("accuracy_vs_delay_{scene}.svg"));
        draw(
            SVGBackend::new(&svg, SIZE).into_drawing_area(),
            scene,
            &rows,
        )?;
        let png = out.join(format!("accuracy_vs_delay_{scene}.png"));
        draw(
            BitMapBackend::new(&png, SIZE).into_drawing_area(),
            scene,
            &rows,
        )?;
        written.extend([svg, png]);
    }
    Ok(written)
}

const SIZE: (u32, u32) = (1600, 420);

fn failed<E: std::fmt::Display>(e: E) -> BenchError {
    BenchError::Chart {
        chart: "of the delays".to_owned(),
        problem: e.to_string(),
    }
}

/// Four panels against the delay: hit recall, routed-op delay in ticks, the largest hand-off
/// jump, final position error.
fn draw<DB: DrawingBackend>(
    area: DrawingArea<DB, plotters::coord::Shift>,
    scene: &str,
    rows: &[&DelayTrial],
) -> BenchResult<()> {
    area.fill(&WHITE).map_err(failed)?;
    let area = area
        .titled(
            &format!("{scene}: two hosts, host b's traffic to Redis delayed (simulated)"),
            ("sans-serif", 20),
        )
        .map_err(failed)?;
    let panels = area.split_evenly((1, 4));
    type Metric = fn(&DelayTrial) -> Option<f64>;
    // Each panel's metric, and the noise floor beside it where it has one.
    let metrics: [(&str, Metric, Option<Metric>); 4] = [
        (
            "projectile hit recall",
            |t| t.result.accuracy.hit_recall,
            None,
        ),
        (
            "routed-op delay p50, ticks",
            |t| Some(t.result.cost.op_delay_p50_ticks as f64),
            None,
        ),
        (
            "largest hand-off jump, m",
            |t| Some(t.result.accuracy.handoff_jump_position_m),
            None,
        ),
        (
            "final position RMS, m",
            |t| Some(t.result.accuracy.position_rms_m),
            Some(|t| Some(t.result.floor.position_rms_m)),
        ),
    ];
    let x_max = rows.iter().map(|t| t.delay_ms).fold(1.0, f64::max) * 1.05;
    for (panel, (label, metric, floor)) in panels.iter().zip(metrics) {
        let series = |metric: Metric| -> Vec<(f64, f64)> {
            rows.iter()
                .filter_map(|t| metric(t).map(|y| (t.delay_ms, y)))
                .collect()
        };
        let points = series(metric);
        let floor_points = floor.map(series).unwrap_or_default();
        let y_max = points
            .iter()
            .chain(&floor_points)
            .map(|p| p.1)
            .fold(0.0, f64::max)
            .max(1e-3)
            * 1.2;
        let mut chart = ChartBuilder::on(panel)
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..x_max, 0.0..y_max)
            .map_err(failed)?;
        chart
            .configure_mesh()
            .x_desc("one-way delay, host b ↔ Redis, ms")
            .y_desc(label)
            .axis_desc_style(("sans-serif", 14))
            .draw()
            .map_err(failed)?;
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                BLUE.stroke_width(2),
            ))
            .map_err(failed)?;
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, 4, BLUE.filled())))
            .map_err(failed)?;
        if !floor_points.is_empty() {
            let green = RGBColor(44, 160, 44);
            chart
                .draw_series(DashedLineSeries::new(
                    floor_points.iter().copied(),
                    8,
                    5,
                    green.stroke_width(2),
                ))
                .map_err(failed)?
                .label("noise floor (farthest of 3 perturbed worlds)")
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x - 10, y), (x + 10, y)], green.stroke_width(2))
                });
            crate::sweep::charts::draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        }
    }
    area.present().map_err(failed)
}
