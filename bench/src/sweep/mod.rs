//! `seam sweep`: accuracy against cost over a grid of settings, as a CSV and charts.
//!
//! Every point of the grid is one [`run_trial`] (a split run in lock-step against its
//! single-world reference, in this process) on each scene: proxy mode × replication interval ×
//! projectile speed × projectile CCD × observation spread (the last value, `everything`, turns
//! interest management off: every cluster proxies every neighbour entity). The quantization
//! axis runs each proxy mode and interval exact and quantized at the scene's own projectiles
//! and spread, side by side. The transport axis
//! runs the scene as free-running pods (`seam run`) on each transport asked for, per proxy mode
//! at the shortest and longest interval ([`run_free_trial`]). Results go to `sweep.csv`, one
//! row per trial with every metric, and to charts (`charts`).

pub(crate) mod charts;
mod csv;

use std::path::{Path, PathBuf};

use seam_proxy::ProxyMode;

use crate::accuracy::{
    FreeRunning, TrialResult, TrialSettings, mode_name, run_free_trial, run_trial,
};
use crate::error::{BenchError, BenchResult, Context};
use crate::scene::Scene;
pub use charts::{chart_font, draw_all};

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
    /// State encodings: `false` exact, `true` quantized. With `true` among them, each proxy
    /// mode and interval also runs once per encoding at the scene's own projectiles and spread;
    /// every other trial is exact.
    pub quantize: Vec<bool>,
    /// Transports for free-running pods (the transport axis), each run per proxy mode at the
    /// shortest and longest interval with the scene's own projectiles and spread.
    pub transports: Vec<String>,
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
            quantize: vec![false, true],
            transports: Vec::new(),
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
            quantize: vec![false, true],
            transports: Vec::new(),
        }
    }

    /// Every combination for `scene`, in a fixed order; the projectile axes only if the scene
    /// fires projectiles (otherwise their trials would all be the same).
    pub fn settings(&self, scene: &Scene, ticks: Option<u64>) -> Vec<TrialSettings> {
        let shoots = scene
            .events
            .iter()
            .any(|e| matches!(e, crate::scene::Event::Projectile { .. }));
        let speeds: Vec<Option<f32>> = if shoots {
            self.speeds.iter().copied().map(Some).collect()
        } else {
            vec![None]
        };
        let ccd: Vec<Option<bool>> = if shoots {
            self.ccd.iter().copied().map(Some).collect()
        } else {
            vec![None]
        };
        let mut all = Vec::new();
        for &proxy_mode in &self.proxy_modes {
            for &replication_interval in &self.intervals {
                // The quantization axis: exact and quantized at the scene's own projectiles
                // and spread, side by side.
                if self.quantize.contains(&true) {
                    for &quantize in &self.quantize {
                        all.push(TrialSettings {
                            proxy_mode,
                            replication_interval,
                            quantize,
                            ticks,
                            ..TrialSettings::default()
                        });
                    }
                }
                for &spread in &self.spreads {
                    for &projectile_ccd in &ccd {
                        for &projectile_speed in &speeds {
                            all.push(TrialSettings {
                                proxy_mode,
                                replication_interval,
                                spread,
                                interest: spread.is_some(),
                                projectile_speed,
                                projectile_ccd,
                                ticks,
                                ..TrialSettings::default()
                            });
                        }
                    }
                }
            }
        }
        all
    }
}

/// The settings of one trial, in words.
pub fn describe(settings: &TrialSettings) -> String {
    let spread = match (settings.interest, settings.spread) {
        (false, _) => "everything".to_owned(),
        (true, Some(s)) => format!("{s} m"),
        (true, None) => "the scene's".to_owned(),
    };
    let speed = settings
        .projectile_speed
        .map_or("the scene's speed".to_owned(), |v| format!("{v} m/s"));
    let ccd = match settings.projectile_ccd {
        Some(true) => "on",
        Some(false) => "off",
        None => "as in the scene",
    };
    format!(
        "{} every {} tick(s){}, spread {spread}, {speed}, CCD {ccd}",
        mode_name(settings.proxy_mode),
        settings.replication_interval,
        if settings.quantize { " quantized" } else { "" },
    )
}

impl SweepGrid {
    /// The free-running trials: proxy mode × {shortest, longest interval} × transport.
    pub fn free_settings(&self, ticks: Option<u64>) -> Vec<(TrialSettings, String)> {
        let mut intervals = vec![
            self.intervals.iter().copied().min().unwrap_or(1),
            self.intervals.iter().copied().max().unwrap_or(1),
        ];
        intervals.dedup();
        let mut all = Vec::new();
        for transport in &self.transports {
            for &proxy_mode in &self.proxy_modes {
                for &replication_interval in &intervals {
                    let settings = TrialSettings {
                        proxy_mode,
                        replication_interval,
                        ticks,
                        ..TrialSettings::default()
                    };
                    all.push((settings, transport.clone()));
                }
            }
        }
        all
    }
}

/// Runs every trial of `grid` on every scene (`(file, scene)`), calling
/// `progress(done, total, line)` after each. Free-running trials start pods with `free`.
pub fn run(
    scenes: &[(PathBuf, Scene)],
    grid: &SweepGrid,
    ticks: Option<u64>,
    free: &FreeRunning,
    mut progress: impl FnMut(usize, usize, &str),
) -> BenchResult<Vec<TrialResult>> {
    let free_settings = grid.free_settings(ticks);
    let total = scenes
        .iter()
        .map(|(_, scene)| grid.settings(scene, ticks).len() + free_settings.len())
        .sum();
    let mut results = Vec::with_capacity(total);
    let mut report = |results: &mut Vec<TrialResult>, result: TrialResult| {
        let line = format!(
            "{} on {}: {} → position RMS {:.4} m, hit recall {}, {:.0} B/tick, op p50 {:.0} µs",
            result.scene,
            seam_transport::redact_url(&result.transport),
            describe(&result.settings),
            result.accuracy.position_rms_m,
            result
                .accuracy
                .hit_recall
                .map_or("-".to_owned(), |v| format!("{v:.2}")),
            result.cost.replication_bytes_per_tick + result.cost.events_bytes_per_tick,
            result.cost.op_whole_p50_us,
        );
        results.push(result);
        progress(results.len(), total, &line);
    };
    for (path, scene) in scenes {
        for trial in &grid.settings(scene, ticks) {
            let result = run_trial(scene, trial, None).context(format!(
                "{}: {}",
                scene.name,
                describe(trial)
            ))?;
            report(&mut results, result);
        }
        for (trial, transport) in &free_settings {
            let run_id = format!("sweep{}x{}", std::process::id(), results.len());
            let result =
                run_free_trial(path, scene, trial, transport, free, &run_id).context(format!(
                    "{} on {}: {}",
                    scene.name,
                    seam_transport::redact_url(transport),
                    describe(trial)
                ))?;
            report(&mut results, result);
        }
    }
    Ok(results)
}

/// Writes `sweep.csv` and the charts into `out`; returns the files written.
pub fn write(results: &[TrialResult], out: &Path) -> BenchResult<Vec<PathBuf>> {
    std::fs::create_dir_all(out).map_err(|e| BenchError::io("create", out.display(), e))?;
    let csv_path = out.join("sweep.csv");
    csv::write(results, &csv_path)?;
    let mut written = vec![csv_path];
    written.extend(draw_all(results, out)?);
    Ok(written)
}
