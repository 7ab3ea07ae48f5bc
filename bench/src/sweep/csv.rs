//! `sweep.csv`: one row per trial, every setting and metric.

use std::fmt::Write as _;
use std::path::Path;

use crate::accuracy::{TrialResult, mode_name};
use crate::error::{BenchError, BenchResult};

/// The header, in column order.
pub(super) const COLUMNS: &[&str] = &[
    "scene",
    "transport",
    "position_basis",
    "proxy_mode",
    "coupling",
    "exchange",
    "quantized",
    "authority",
    "handoff_margin_m",
    "handoff_dwell",
    "replication_interval",
    "spread_m",
    "interest",
    "projectile_speed_mps",
    "projectile_ccd",
    "ticks",
    "position_rms_m",
    "position_max_m",
    "onset_tick",
    "floor_position_rms_m",
    "floor_position_max_m",
    "floor_onset_tick",
    "rotation_rms_deg",
    "rotation_max_deg",
    "hits_reference",
    "hits_split",
    "hits_matched",
    "hit_recall",
    "hit_precision",
    "hit_tick_offset_mean",
    "momentum_error_max",
    "momentum_error_rel",
    "momentum_drift_rel",
    "handoffs",
    "handoffs_untracked",
    "handoff_jump_position_m",
    "handoff_jump_velocity_mps",
    "step_jump_position_m",
    "step_jump_velocity_mps",
    "floor_step_jump_position_m",
    "floor_step_jump_velocity_mps",
    "floor_worlds",
    "at_floor",
    "duplicate_owner_ticks",
    "missing_entity_ticks",
    "in_transit_ticks",
    "escaped_bodies",
    "tick_p50_us",
    "tick_p99_us",
    "tick_sum_p50_us",
    "reference_tick_p50_us",
    "replication_bytes_per_tick",
    "replication_bytes_per_state",
    "events_bytes_per_tick",
    "proxies_mean",
    "ops",
    "op_delay_p50_ticks",
    "op_delay_max_ticks",
    "op_whole_p50_us",
    "op_whole_p99_us",
    "op_transport_p50_us",
];

/// One row.
pub(super) fn row(r: &TrialResult) -> String {
    let (s, a, c) = (&r.settings, &r.accuracy, &r.cost);
    let mut out = String::new();
    let fields: Vec<String> = vec![
        r.scene.clone(),
        r.transport.clone(),
        r.position_basis.to_owned(),
        mode_name(s.proxy_mode).to_owned(),
        s.coupling.to_string(),
        s.exchange.to_string(),
        s.quantize.to_string(),
        s.authority.authority.name().to_owned(),
        s.authority.handoff_margin.to_string(),
        s.authority.handoff_dwell.to_string(),
        s.replication_interval.to_string(),
        s.spread.map_or("everything".to_owned(), |v| v.to_string()),
        s.interest.to_string(),
        s.projectile_speed.map_or(String::new(), |v| v.to_string()),
        s.projectile_ccd.map_or(String::new(), |v| v.to_string()),
        r.ticks.to_string(),
        format!("{:.6}", a.position_rms_m),
        format!("{:.6}", a.position_max_m),
        a.onset_tick.map_or(String::new(), |t| t.to_string()),
        format!("{:.6}", r.floor.position_rms_m),
        format!("{:.6}", r.floor.position_max_m),
        r.floor.onset_tick.map_or(String::new(), |t| t.to_string()),
        format!("{:.4}", a.rotation_rms_deg),
        format!("{:.4}", a.rotation_max_deg),
        a.hits_reference.to_string(),
        a.hits_split.to_string(),
        a.hits_matched.to_string(),
        a.hit_recall.map_or(String::new(), |v| format!("{v:.4}")),
        a.hit_precision.map_or(String::new(), |v| format!("{v:.4}")),
        format!("{:.3}", a.hit_tick_offset_mean),
        format!("{:.4}", a.momentum_error_max),
        format!("{:.5}", a.momentum_error_rel),
        format!("{:.5}", a.momentum_drift_rel),
        a.handoffs.to_string(),
        a.handoffs_untracked.to_string(),
        format!("{:.6}", a.handoff_jump_position_m),
        format!("{:.6}", a.handoff_jump_velocity_mps),
        format!("{:.6}", a.step_jump_position_m),
        format!("{:.6}", a.step_jump_velocity_mps),
        format!("{:.6}", r.floor.step_jump_position_m),
        format!("{:.6}", r.floor.step_jump_velocity_mps),
        r.floor_worlds.len().to_string(),
        crate::accuracy::beyond_floor(a, &r.floor)
            .is_empty()
            .to_string(),
        a.duplicate_owner_ticks.to_string(),
        a.missing_entity_ticks.to_string(),
        a.in_transit_ticks.to_string(),
        a.escaped_bodies.to_string(),
        format!("{:.1}", c.tick_p50_us),
        format!("{:.1}", c.tick_p99_us),
        format!("{:.1}", c.tick_sum_p50_us),
        format!("{:.1}", c.reference_tick_p50_us),
        format!("{:.1}", c.replication_bytes_per_tick),
        format!("{:.1}", c.bytes_per_state),
        format!("{:.1}", c.events_bytes_per_tick),
        format!("{:.2}", c.proxies_mean),
        c.ops.to_string(),
        c.op_delay_p50_ticks.to_string(),
        c.op_delay_max_ticks.to_string(),
        format!("{:.1}", c.op_whole_p50_us),
        format!("{:.1}", c.op_whole_p99_us),
        format!("{:.1}", c.op_transport_p50_us),
    ];
    debug_assert_eq!(fields.len(), COLUMNS.len());
    let _ = write!(out, "{}", fields.join(","));
    out
}

/// Writes the header and one row per result.
pub(super) fn write(results: &[TrialResult], path: &Path) -> BenchResult<()> {
    let mut text = COLUMNS.join(",");
    text.push('\n');
    for r in results {
        text += &row(r);
        text.push('\n');
    }
    std::fs::write(path, text).map_err(|e| BenchError::io("write", path.display(), e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accuracy::{Accuracy, Cost, TrialSettings};

    fn trial(rms: f64, floor_rms: f64) -> TrialResult {
        TrialResult {
            scene: "s".to_owned(),
            transport: "lockstep".to_owned(),
            position_basis: "every tick",
            settings: TrialSettings::default(),
            ticks: 10,
            accuracy: Accuracy {
                position_rms_m: rms,
                ..Accuracy::default()
            },
            floor: Accuracy {
                position_rms_m: floor_rms,
                ..Accuracy::default()
            },
            floor_worlds: vec![Default::default(); 3],
            cost: Cost::default(),
        }
    }

    /// Every row has a field per column, and says whether the trial is at its floor as the
    /// text's verdict does.
    #[test]
    fn a_row_has_every_column_and_the_floors_verdict() {
        let field = |r: &TrialResult, name: &str| {
            let at = COLUMNS.iter().position(|c| *c == name).expect(name);
            row(r).split(',').nth(at).map(str::to_owned)
        };
        let at = trial(0.02, 0.1);
        assert_eq!(row(&at).split(',').count(), COLUMNS.len());
        assert_eq!(field(&at, "at_floor").as_deref(), Some("true"));
        assert_eq!(field(&at, "floor_worlds").as_deref(), Some("3"));
        let beyond = trial(0.5, 0.1);
        assert_eq!(field(&beyond, "at_floor").as_deref(), Some("false"));
    }
}
