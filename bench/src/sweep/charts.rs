//! The sweep's charts, as SVG and PNG: for every scene, accuracy against cost — CPU time per
//! tick summed over the clusters, and bytes published per tick — with the Pareto front marked;
//! and for every scene with hits, projectile hit recall against speed for each proxy mode.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use seam_proxy::ProxyMode;

use crate::accuracy::{TrialResult, mode_name};
use crate::error::{BenchError, BenchResult};

/// Where a TrueType font for chart text is looked for (`SEAM_FONT` first).
const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
];

/// Registers a font for chart text once; plotters needs one to measure and draw labels.
pub fn chart_font() -> BenchResult<()> {
    // What is wrong with the fonts, if anything, found once.
    static FONT: OnceLock<Option<String>> = OnceLock::new();
    let problem = FONT.get_or_init(|| {
        let from_env = std::env::var("SEAM_FONT").ok();
        let candidates = from_env
            .iter()
            .map(String::as_str)
            .chain(FONT_PATHS.iter().copied());
        for path in candidates {
            if let Ok(bytes) = std::fs::read(path) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                return plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
                    .err()
                    .map(|_| format!("{path} is not a usable TrueType font"));
            }
        }
        Some(format!(
            "no font for chart text: install fonts-dejavu-core or set SEAM_FONT to a .ttf file \
             (looked in {})",
            FONT_PATHS.join(", ")
        ))
    });
    match problem {
        None => Ok(()),
        Some(problem) => Err(BenchError::Chart {
            chart: "text".to_owned(),
            problem: problem.clone(),
        }),
    }
}

/// One chart, drawable on any backend.
enum Chart<'a> {
    AccuracyVsCost {
        scene: String,
        rows: Vec<&'a TrialResult>,
    },
    HitRecall {
        scene: String,
        mode: ProxyMode,
        rows: Vec<&'a TrialResult>,
    },
}

impl Chart<'_> {
    fn draw<DB: DrawingBackend>(&self, area: DrawingArea<DB, Shift>) -> BenchResult<()> {
        match self {
            Chart::AccuracyVsCost { scene, rows } => accuracy_vs_cost(area, scene, rows),
            Chart::HitRecall { scene, mode, rows } => hit_recall_vs_speed(area, scene, *mode, rows),
        }
    }

    /// Writes `out/name.svg` and `out/name.png`.
    fn write(&self, out: &Path, name: &str) -> BenchResult<[PathBuf; 2]> {
        let svg = out.join(format!("{name}.svg"));
        self.draw(SVGBackend::new(&svg, SIZE).into_drawing_area())?;
        let png = out.join(format!("{name}.png"));
        self.draw(BitMapBackend::new(&png, SIZE).into_drawing_area())?;
        Ok([svg, png])
    }
}

/// Draws every chart into `out`, each as `.svg` and `.png`: `accuracy_vs_cost_SCENE` for
/// every scene, `hit_recall_vs_speed_SCENE_MODE` for every scene whose single world has hits.
/// Returns the files written.
pub fn draw_all(results: &[TrialResult], out: &Path) -> BenchResult<Vec<PathBuf>> {
    chart_font()?;
    let mut written = Vec::new();
    // The charts compare settings in lock-step, where runs are deterministic; free-running
    // rows (the transport axis) are in the CSV.
    let results: Vec<TrialResult> = results
        .iter()
        .filter(|r| r.transport == "lockstep")
        .cloned()
        .collect();
    let mut scenes: Vec<String> = results.iter().map(|r| r.scene.clone()).collect();
    scenes.dedup();
    for scene in &scenes {
        let rows: Vec<&TrialResult> = results.iter().filter(|r| &r.scene == scene).collect();
        let name = format!("accuracy_vs_cost_{scene}");
        let chart = Chart::AccuracyVsCost {
            scene: scene.clone(),
            rows: rows.clone(),
        };
        written.extend(chart.write(out, &name)?);
        if rows.iter().all(|r| r.accuracy.hits_reference == 0) {
            continue;
        }
        for mode in [ProxyMode::Fixed, ProxyMode::KinematicVelocityBased] {
            let rows: Vec<&TrialResult> = rows
                .iter()
                .copied()
                .filter(|r| r.settings.proxy_mode == mode && r.settings.projectile_speed.is_some())
                .collect();
            if rows.is_empty() {
                continue;
            }
            let name = format!("hit_recall_vs_speed_{scene}_{}", mode_name(mode));
            let chart = Chart::HitRecall {
                scene: scene.clone(),
                mode,
                rows,
            };
            written.extend(chart.write(out, &name)?);
        }
    }
    Ok(written)
}

const SIZE: (u32, u32) = (1200, 560);

fn failed<E: std::fmt::Display>(e: E) -> BenchError {
    BenchError::Chart {
        chart: "being drawn".to_owned(),
        problem: e.to_string(),
    }
}

/// The legend every chart draws, at `position` (`seam network`'s too).
pub(crate) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> BenchResult<()> {
    chart
        .configure_series_labels()
        .position(position)
        .label_font(("sans-serif", 16))
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()
        .map_err(failed)
}

fn color_of(mode: ProxyMode) -> RGBColor {
    match mode {
        ProxyMode::Fixed => RGBColor(31, 119, 180),
        _ => RGBColor(214, 39, 40),
    }
}

/// The accuracy axis of a chart that measures position error.
const POSITION_ERROR: &str = "position error, RMS over bodies and ticks (m, log)";

/// What a chart of `rows` measures accuracy by: the bodies' position error where they have any,
/// else (shots at kinematic targets) the hits missed or extra, 2 − recall − precision.
fn error_of(rows: &[&TrialResult]) -> (&'static str, fn(&TrialResult) -> f64) {
    if rows.iter().any(|r| r.accuracy.position_rms_m > 0.0) {
        (POSITION_ERROR, |r| r.accuracy.position_rms_m)
    } else {
        ("hit error: 2 − recall − precision (log)", |r| {
            2.0 - r.accuracy.hit_recall.unwrap_or(1.0) - r.accuracy.hit_precision.unwrap_or(1.0)
        })
    }
}

/// Accuracy against cost, one point per trial, in two panels: CPU time per tick summed over
/// the clusters (each cluster's median; the single world's marked by a line), and bytes
/// published per tick. The Pareto front (no other trial both cheaper and more accurate) is
/// joined by a line.
fn accuracy_vs_cost<DB: DrawingBackend>(
    area: DrawingArea<DB, Shift>,
    scene: &str,
    rows: &[&TrialResult],
) -> BenchResult<()> {
    area.fill(&WHITE).map_err(failed)?;
    let (label, error) = error_of(rows);
    // The floor of position error: one world against itself perturbed (every trial of a
    // scene has the same; the largest is drawn).
    let floor = (label == POSITION_ERROR).then(|| {
        rows.iter()
            .map(|r| r.floor.position_rms_m)
            .fold(0.0, f64::max)
    });
    let title = match floor {
        Some(floor) if floor >= 0.01 => format!(
            "{scene} (chaotic: one world perturbed at round-off ends up to {floor:.2} m RMS off): \
             accuracy against cost"
        ),
        _ => format!("{scene}: accuracy against cost (one point per setting)"),
    };
    let area = area.titled(&title, ("sans-serif", 22)).map_err(failed)?;
    let (left, right) = area.split_horizontally(SIZE.0 / 2);
    let one_world = rows
        .iter()
        .map(|r| r.cost.reference_tick_p50_us / 1000.0)
        .sum::<f64>()
        / rows.len().max(1) as f64;
    let panels: [Panel; 2] = [
        Panel {
            x_label: "CPU per tick, clusters summed (ms)",
            cost: |r| r.cost.tick_sum_p50_us / 1000.0,
            reference: Some(one_world),
            floor,
        },
        Panel {
            x_label: "bytes published per tick, all clusters (kB)",
            cost: |r| (r.cost.replication_bytes_per_tick + r.cost.events_bytes_per_tick) / 1000.0,
            reference: None,
            floor,
        },
    ];
    for (panel, half) in panels.iter().zip([left, right]) {
        panel.draw(half, rows, label, error)?;
    }
    area.present().map_err(failed)
}

/// One panel of [`accuracy_vs_cost`].
struct Panel {
    x_label: &'static str,
    cost: fn(&TrialResult) -> f64,
    /// The single world's cost, marked by a vertical line.
    reference: Option<f64>,
    /// The noise floor of the error, marked by a horizontal line.
    floor: Option<f64>,
}

impl Panel {
    fn draw<DB: DrawingBackend>(
        &self,
        area: DrawingArea<DB, Shift>,
        rows: &[&TrialResult],
        y_label: &str,
        error: fn(&TrialResult) -> f64,
    ) -> BenchResult<()> {
        let points: Vec<(f64, f64, ProxyMode)> = rows
            .iter()
            .map(|r| ((self.cost)(r), error(r).max(1e-6), r.settings.proxy_mode))
            .collect();
        let x_max = points
            .iter()
            .map(|p| p.0)
            .chain(self.reference)
            .fold(0.0, f64::max)
            * 1.1
            + 1e-3;
        let floor = self.floor.map(|f| f.max(1e-6));
        let y_min = points
            .iter()
            .map(|p| p.1)
            .chain(floor)
            .fold(f64::INFINITY, f64::min)
            * 0.5;
        let y_max = points.iter().map(|p| p.1).chain(floor).fold(0.0, f64::max) * 2.0;
        let mut front: Vec<(f64, f64)> = points.iter().map(|p| (p.0, p.1)).collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let mut pareto: Vec<(f64, f64)> = Vec::new();
        for p in front {
            if pareto.last().is_none_or(|last| p.1 < last.1) {
                pareto.push(p);
            }
        }
        let mut chart = ChartBuilder::on(&area)
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..x_max, (y_min..y_max).log_scale())
            .map_err(failed)?;
        chart
            .configure_mesh()
            .x_desc(self.x_label)
            .y_desc(y_label)
            .axis_desc_style(("sans-serif", 14))
            .draw()
            .map_err(failed)?;
        for mode in [ProxyMode::Fixed, ProxyMode::KinematicVelocityBased] {
            let color = color_of(mode);
            chart
                .draw_series(
                    points
                        .iter()
                        .filter(|p| p.2 == mode)
                        .map(|p| Circle::new((p.0, p.1), 4, color.filled())),
                )
                .map_err(failed)?
                .label(format!("{} proxies", mode_name(mode)))
                .legend(move |(x, y)| Circle::new((x, y), 4, color.filled()));
        }
        chart
            .draw_series(LineSeries::new(
                pareto.iter().copied(),
                BLACK.stroke_width(2),
            ))
            .map_err(failed)?
            .label("Pareto front")
            .legend(|(x, y)| {
                PathElement::new(vec![(x - 10, y), (x + 10, y)], BLACK.stroke_width(2))
            });
        if let Some(x) = self.reference {
            let grey = RGBColor(120, 120, 120);
            chart
                .draw_series(LineSeries::new(
                    [(x, y_min), (x, y_max)],
                    grey.stroke_width(2),
                ))
                .map_err(failed)?
                .label("one world")
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x - 10, y), (x + 10, y)], grey.stroke_width(2))
                });
        }
        if let Some(y) = floor {
            let green = RGBColor(44, 160, 44);
            chart
                .draw_series(DashedLineSeries::new(
                    [(0.0, y), (x_max, y)],
                    8,
                    5,
                    green.stroke_width(2),
                ))
                .map_err(failed)?
                .label("noise floor (farthest of 3 perturbed worlds)")
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x - 10, y), (x + 10, y)], green.stroke_width(2))
                });
        }
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight)
    }
}

/// The rows [`hit_recall_vs_speed`] draws: the shortest and longest replication interval,
/// with proxies for everything if the sweep has that, else at the widest spread (returned).
fn hit_recall_rows<'a>(rows: &'a [&'a TrialResult]) -> (Option<f32>, Vec<&'a &'a TrialResult>) {
    let spread = if rows.iter().any(|r| r.settings.spread.is_none()) {
        None
    } else {
        rows.iter()
            .filter_map(|r| r.settings.spread)
            .max_by(f32::total_cmp)
    };
    let intervals: Vec<u64> = rows
        .iter()
        .map(|r| r.settings.replication_interval)
        .collect();
    let shown = [
        intervals.iter().copied().min().unwrap_or(1),
        intervals.iter().copied().max().unwrap_or(1),
    ];
    let rows: Vec<&&TrialResult> = rows
        .iter()
        .filter(|r| r.settings.spread == spread && shown.contains(&r.settings.replication_interval))
        .collect();
    (spread, rows)
}

/// Hit recall against projectile speed, one line per (CCD, replication interval) for the
/// shortest and longest interval, with proxies for everything if the sweep has that (so the
/// proxy mode shows, not the interest region), else at the widest spread.
fn hit_recall_vs_speed<DB: DrawingBackend>(
    area: DrawingArea<DB, Shift>,
    scene: &str,
    mode: ProxyMode,
    rows: &[&TrialResult],
) -> BenchResult<()> {
    let (spread, rows) = hit_recall_rows(rows);
    let speeds: Vec<f64> = rows
        .iter()
        .filter_map(|r| r.settings.projectile_speed.map(f64::from))
        .collect();
    let x_min = speeds
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .max(1.0)
        * 0.8;
    let x_max = speeds.iter().copied().fold(0.0, f64::max).max(x_min * 2.0) * 1.25;
    area.fill(&WHITE).map_err(failed)?;
    let spread_text = spread.map_or("everything".to_owned(), |s| format!("{s} m"));
    let spread_text = if spread.is_none() {
        "proxies for everything".to_owned()
    } else {
        format!("spread {spread_text}")
    };
    let mut chart = ChartBuilder::on(&area)
        .caption(
            format!(
                "{scene}: projectile hits found, {} proxies ({spread_text})",
                mode_name(mode)
            ),
            ("sans-serif", 24),
        )
        .margin(20)
        .x_label_area_size(55)
        .y_label_area_size(70)
        .build_cartesian_2d((x_min..x_max).log_scale(), 0.0..1.05)
        .map_err(failed)?;
    chart
        .configure_mesh()
        .x_desc("projectile speed (m/s, log)")
        .x_labels(6)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_desc("hit recall (hits found / hits in the single world)")
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(failed)?;
    let mut series: Vec<(bool, u64)> = rows
        .iter()
        .map(|r| {
            (
                r.settings.projectile_ccd == Some(true),
                r.settings.replication_interval,
            )
        })
        .collect();
    series.sort_unstable();
    series.dedup();
    for (index, (ccd, interval)) in series.into_iter().enumerate() {
        let color = Palette99::pick(index).to_rgba();
        let mut line: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| {
                r.settings.projectile_ccd == Some(ccd)
                    && r.settings.replication_interval == interval
            })
            .filter_map(|r| {
                // No hits in the single world: recall is undefined, not a point.
                Some((
                    f64::from(r.settings.projectile_speed?),
                    r.accuracy.hit_recall?,
                ))
            })
            .collect();
        if line.is_empty() {
            continue;
        }
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        let label = format!(
            "CCD {}, replication every {interval} tick(s)",
            if ccd { "on" } else { "off" }
        );
        let style = color.stroke_width(if ccd { 3 } else { 2 });
        chart
            .draw_series(LineSeries::new(line.iter().copied(), style))
            .map_err(failed)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], style));
        chart
            .draw_series(line.iter().map(|&p| Circle::new(p, 3, color.filled())))
            .map_err(failed)?;
    }
    draw_legend(&mut chart, SeriesLabelPosition::LowerLeft)?;
    area.present().map_err(failed)
}
