//! `seam capacity`'s report as a [`Document`]: text for the terminal, Markdown for
//! BENCHMARKS.md.

use super::{CapacityReport, Probe, RowResult};
use crate::document::{Align, Document, Table, grouped};

/// ms, two decimals.
fn ms(ns: u64) -> String {
    format!("{:.2}", ns as f64 / 1e6)
}

fn ratio(a: u64, b: u64) -> String {
    if b == 0 {
        "-".to_owned()
    } else {
        format!("{:.2}", a as f64 / b as f64)
    }
}

/// The cells of one row: largest size, its bodies and their ratio to the first row's, wall
/// and CPU time there; wall and CPU at the common size and CPU's ratio to the first row's.
fn cells(row: &RowResult, first: &RowResult) -> Vec<String> {
    let times = |p: &Option<Probe>| match p {
        Some(p) => [ms(p.wall_p50_ns), ms(p.wall_p99_ns), ms(p.cpu_p50_ns)],
        None => ["-".to_owned(), "-".to_owned(), "-".to_owned()],
    };
    let [wall_p50, wall_p99, cpu] = times(&row.at_largest);
    let common_cpu = |r: &RowResult| r.at_common.as_ref().map_or(0, |p| p.cpu_p50_ns);
    let common_wall = row.at_common.as_ref().map_or(0, |p| p.wall_p50_ns);
    let capped = if row.capped { "+" } else { "" };
    vec![
        row.row.clone(),
        format!("{}{capped}", row.layers),
        grouped(row.bodies),
        ratio(row.bodies, first.bodies),
        wall_p50,
        wall_p99,
        cpu,
        ms(common_wall),
        ms(common_cpu(row)),
        ratio(common_cpu(row), common_cpu(first)),
    ]
}

/// The report.
pub fn document(report: &CapacityReport) -> Document {
    let mut doc = Document::new();
    doc.line(format!(
        "seam capacity: {} at {} Hz on {} cores, {} ticks a probe; a size holds with at most \
         {:.1} % of each pod's (each world's) ticks over {:.1} ms; {} bodies a layer; scripted events left out",
        report.scene,
        report.rate,
        report.cores,
        report.ticks,
        report.max_overrun * 100.0,
        1e3 / report.rate,
        grouped(report.bodies_per_layer)
    ));
    doc.line("");
    let Some(first) = report.rows.first() else {
        return doc;
    };
    let common = grouped(first.at_common.as_ref().map_or(0, |p| p.bodies));
    let at_common_wall = format!("at {common}: wall p50 ms");
    let mut table = Table::new(&[
        ("row", Align::Left),
        ("layers", Align::Right),
        ("bodies", Align::Right),
        ("x first", Align::Right),
        ("wall p50 ms", Align::Right),
        ("wall p99 ms", Align::Right),
        ("CPU p50 ms", Align::Right),
        (&at_common_wall, Align::Right),
        ("CPU p50 ms", Align::Right),
        ("CPU x first", Align::Right),
    ]);
    for row in &report.rows {
        table.row(cells(row, first));
    }
    doc.table(table);
    doc.line("");
    doc.line(
        "layers: the largest size held (+: still holding at --max-layers), wall and CPU time \
         per tick there (seam: the slowest pod's wall, the pods' CPU summed); then at the first \
         row's largest size, wall and CPU, and CPU against the first row's there.",
    );
    let phased: Vec<(&RowResult, &Probe)> = (report.rows.iter())
        .filter_map(|r| r.at_common.as_ref().map(|p| (r, p)))
        .filter(|(_, p)| !p.phases_ms.is_empty())
        .collect();
    if let Some((_, probe)) = phased.first() {
        doc.line("");
        doc.line(format!(
            "Where seam's CPU goes at {common}: thread CPU per tick by phase, mean ms, pods summed"
        ));
        let names: Vec<&str> = probe.phases_ms.iter().map(|(n, _)| n.as_str()).collect();
        let mut columns = vec![("row", Align::Left)];
        columns.extend(names.iter().map(|n| (*n, Align::Right)));
        columns.extend([
            ("sum", Align::Right),
            ("pairs with proxy", Align::Right),
            ("contacts with proxy", Align::Right),
        ]);
        let mut phases = Table::new(&columns);
        for (row, probe) in phased {
            let mut cells = vec![row.row.clone()];
            cells.extend(probe.phases_ms.iter().map(|(_, v)| format!("{v:.2}")));
            let sum: f64 = probe.phases_ms.iter().map(|(_, v)| v).sum();
            cells.push(format!("{sum:.2}"));
            let (pairs, contacts) = probe.proxy_shares.unwrap_or_default();
            cells.push(format!("{:.0} %", pairs * 100.0));
            cells.push(format!("{:.0} %", contacts * 100.0));
            phases.row(cells);
        }
        doc.table(phases);
        doc.line(
            "phases as `seam run` prints them (receive: frames taken in; exchange: routed ops \
             before the step; publish: the policy asked, frames encoded and sent); pairs: the \
             share of Rapier's narrow-phase pairs, and of its contact points, that have a proxy",
        );
    }
    doc
}
