//! Where each pod's thread CPU goes, phase by phase, and how much of Rapier's narrow phase is
//! pairs with proxies: the table `seam run` prints after the pods'.

use super::RunReport;
use crate::document::{Align::*, Table};

/// What the phases table shows, printed under it.
pub(super) const PHASES_NOTE: &str = "thread CPU per tick by phase, mean ms (receive: frames \
     taken in between ticks and at a tick's start; exchange: routed ops to and from owners \
     before the step; waiting for neighbours costs no CPU and is not here); pairs: Rapier's \
     narrow phase after a step, mean of samples every 30 ticks, with the share that has a \
     proxy on one side or both";

/// A row per pod: each phase's mean, their sum, and the narrow phase's pairs.
pub(super) fn phases_table(report: &RunReport) -> Table {
    let names: Vec<String> = (report.pods.iter())
        .find(|p| !p.phases_ms.is_empty())
        .map(|p| p.phases_ms.iter().map(|(n, _)| n.clone()).collect())
        .unwrap_or_default();
    let mut columns: Vec<(&str, _)> = vec![("pod", Left)];
    columns.extend(names.iter().map(|n| (n.as_str(), Right)));
    columns.extend([
        ("sum", Right),
        ("pairs", Right),
        ("with proxy", Right),
        ("proxy-proxy", Right),
        ("touching", Right),
        ("with proxy", Right),
        ("proxy-proxy", Right),
        ("contacts with proxy", Right),
    ]);
    let mut table = Table::new(&columns);
    for p in &report.pods {
        let mut row = vec![p.cluster.clone()];
        row.extend(p.phases_ms.iter().map(|(_, ms)| format!("{ms:.3}")));
        let sum: f64 = p.phases_ms.iter().map(|(_, ms)| ms).sum();
        row.push(format!("{sum:.3}"));
        let c = &p.pairs;
        let share = |part: f64, whole: f64| {
            if whole > 0.0 {
                format!("{:.0} %", 100.0 * part / whole)
            } else {
                "-".to_owned()
            }
        };
        row.extend([
            format!("{:.0}", c.pairs),
            share(c.pairs_with_proxy, c.pairs),
            share(c.pairs_between_proxies, c.pairs),
            format!("{:.0}", c.touching),
            share(c.touching_with_proxy, c.touching),
            share(c.touching_between_proxies, c.touching),
            share(c.contacts_with_proxy, c.contacts),
        ]);
        table.row(row);
    }
    table
}
