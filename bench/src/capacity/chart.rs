//! `seam capacity`'s chart, as SVG and PNG: for each row, the most bodies it holds at the rate
//! (bars), and beside each bar its CPU per tick at the common size against the first row's.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::CapacityReport;
use crate::error::{BenchError, BenchResult};

const SIZE: (u32, u32) = (1100, 520);

fn failed<E: std::fmt::Display>(e: E) -> BenchError {
    BenchError::Chart {
        chart: "capacity".to_owned(),
        problem: e.to_string(),
    }
}

/// Writes `out/capacity_SCENE.svg` and `.png`; returns them.
pub fn draw(report: &CapacityReport, out: &Path) -> BenchResult<[PathBuf; 2]> {
    crate::sweep::chart_font()?;
    std::fs::create_dir_all(out).map_err(|e| BenchError::io("create", out.display(), e))?;
    let name = format!("capacity_{}", report.scene);
    let svg = out.join(format!("{name}.svg"));
    bars(report, SVGBackend::new(&svg, SIZE).into_drawing_area())?;
    let png = out.join(format!("{name}.png"));
    bars(report, BitMapBackend::new(&png, SIZE).into_drawing_area())?;
    Ok([svg, png])
}

fn bars<DB: DrawingBackend>(
    report: &CapacityReport,
    area: DrawingArea<DB, Shift>,
) -> BenchResult<()> {
    area.fill(&WHITE).map_err(failed)?;
    let rows = &report.rows;
    let most = rows.iter().map(|r| r.bodies).max().unwrap_or(1).max(1) as f64 * 1.6;
    let first_cpu = rows
        .first()
        .and_then(|r| r.at_common.as_ref())
        .map_or(0, |p| p.cpu_p50_ns);
    let mut chart = ChartBuilder::on(&area)
        .caption(
            format!(
                "{}: most bodies held at {} Hz ({} cores, ≤ {:.1} % of ticks over)",
                report.scene,
                report.rate,
                report.cores,
                report.max_overrun * 100.0
            ),
            ("sans-serif", 22),
        )
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(380)
        .build_cartesian_2d(
            0.0..most,
            // n segments, one a row.
            (0..rows.len().saturating_sub(1)).into_segmented(),
        )
        .map_err(failed)?;
    let labels: Vec<String> = rows.iter().map(|r| r.row.clone()).collect();
    chart
        .configure_mesh()
        .disable_y_mesh()
        .x_desc("bodies held")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| match v {
            SegmentValue::CenterOf(i) => labels.get(*i).cloned().unwrap_or_default(),
            _ => String::new(),
        })
        .label_style(("sans-serif", 16))
        .draw()
        .map_err(failed)?;
    for (i, row) in rows.iter().enumerate() {
        let seam = row.row.starts_with("seam");
        let color = if seam {
            RGBColor(214, 39, 40)
        } else {
            RGBColor(31, 119, 180)
        };
        let bodies = row.bodies as f64;
        chart
            .draw_series(
                Histogram::horizontal(&chart)
                    .style(color.mix(0.8).filled())
                    .margin(14)
                    .data(std::iter::once((i, bodies))),
            )
            .map_err(failed)?;
        let cpu = row.at_common.as_ref().map_or(0, |p| p.cpu_p50_ns);
        let against = if first_cpu > 0 {
            format!(
                ", CPU/tick {:.2}x first row's",
                cpu as f64 / first_cpu as f64
            )
        } else {
            String::new()
        };
        chart
            .draw_series(std::iter::once(Text::new(
                format!(" {}{against}", row.bodies),
                (bodies, SegmentValue::CenterOf(i)),
                ("sans-serif", 16),
            )))
            .map_err(failed)?;
    }
    area.present().map_err(failed)
}
