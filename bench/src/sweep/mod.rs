//! `seam sweep`: accuracy against cost over a grid of settings, as a CSV and charts.
//!
//! Every point of the grid is one [`run_trial`] (a split run in lock-step against its
//! single-world reference, in this process) on each scene: proxy mode × replication interval ×
//! projectile speed × projectile CCD × observation spread (the last value, `everything`, turns
//! interest management off: every cluster proxies every neighbour entity). Results go to
//! `sweep.csv`, one row per trial with every metric, and to charts (`charts`).

mod charts;
mod csv;

use std::path::{Path, PathBuf};

use seam_proxy::ProxyMode;

use crate::accuracy::{TrialResult, TrialSettings, mode_name, run_trial};
use crate::scene::Scene;
pub use charts::draw_all;

/// The values of each axis.
#[derive(Debug, Clone)]
pub struct SweepGrid {
    /// Proxy modes.
    pub proxy_modes: Vec<ProxyMode>,
    /// Replication intervals, ticks.
    pub intervals: Vec<u64>,
    /// Projectile speeds, m/s.
    pub speeds: Vec<f32>,
    /// Projectile CCD.
    pub ccd: Vec<bool>,
    /// Observation spreads, m; `None` is "everything" (no interest management).
    pub spreads: Vec<Option<f32>>,
}

impl SweepGrid {
    /// The full grid.
    pub fn full() -> Self {
        Self {
            proxy_modes: vec![ProxyMode::Fixed, ProxyMode::KinematicVelocityBased],
            intervals: vec![1, 2, 4, 8],
            speeds: vec![10.0, 50.0, 200.0, 500.0, 1000.0, 2000.0],
            ccd: vec![false, true],
            spreads: vec![Some(1.0), Some(3.0), Some(10.0), None],
        }
    }

    /// A reduced grid (`--quick`).
    pub fn quick() -> Self {
        Self {
            proxy_modes: vec![ProxyMode::Fixed, ProxyMode::KinematicVelocityBased],
            intervals: vec![1, 4],
            speeds: vec![50.0, 500.0, 2000.0],
            ccd: vec![false, true],
            spreads: vec![Some(3.0), None],
        }
    }

    /// Every combination, in a fixed order.
    pub fn settings(&self, ticks: Option<u64>) -> Vec<TrialSettings> {
        let mut all = Vec::new();
        for &proxy_mode in &self.proxy_modes {
            for &replication_interval in &self.intervals {
                for &spread in &self.spreads {
                    for &ccd in &self.ccd {
                        for &speed in &self.speeds {
                            all.push(TrialSettings {
                                proxy_mode,
                                replication_interval,
                                spread,
                                interest: spread.is_some(),
                                projectile_speed: Some(speed),
                                projectile_ccd: Some(ccd),
                                ticks,
                            });
                        }
                    }
                }
            }
        }
        all
    }
}

/// One line of progress: where the sweep is and what the last trial gave.
pub fn describe(settings: &TrialSettings) -> String {
    format!(
        "{} every {} tick(s), spread {}, {} m/s, CCD {}",
        mode_name(settings.proxy_mode),
        settings.replication_interval,
        settings
            .spread
            .map_or("everything".to_owned(), |s| format!("{s} m")),
        settings.projectile_speed.unwrap_or(0.0),
        if settings.projectile_ccd == Some(true) {
            "on"
        } else {
            "off"
        },
    )
}

/// Runs every trial of `grid` on every scene, calling `progress(done, total, line)` after
/// each.
pub fn run(
    scenes: &[Scene],
    grid: &SweepGrid,
    ticks: Option<u64>,
    mut progress: impl FnMut(usize, usize, &str),
) -> Result<Vec<TrialResult>, String> {
    let settings = grid.settings(ticks);
    let total = settings.len() * scenes.len();
    let mut results = Vec::with_capacity(total);
    for scene in scenes {
        for trial in &settings {
            let run_id = format!("sweep{}", results.len());
            let result = run_trial(scene, trial, &run_id)
                .map_err(|e| format!("{}: {}: {e}", scene.name, describe(trial)))?;
            progress(
                results.len() + 1,
                total,
                &format!(
                    "{}: {} → position RMS {:.4} m, hit recall {}, {:.0} B/tick",
                    scene.name,
                    describe(trial),
                    result.accuracy.position_rms_m,
                    result
                        .accuracy
                        .hit_recall
                        .map_or("-".to_owned(), |v| format!("{v:.2}")),
                    result.cost.replication_bytes_per_tick + result.cost.events_bytes_per_tick
                ),
            );
            results.push(result);
        }
    }
    Ok(results)
}

/// Writes `sweep.csv` and the charts into `out`; returns the files written.
pub fn write(results: &[TrialResult], out: &Path) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let csv_path = out.join("sweep.csv");
    csv::write(results, &csv_path)?;
    let mut written = vec![csv_path];
    written.extend(draw_all(results, out)?);
    Ok(written)
}
