//! `seam capacity` finds a size for plain Rapier and for seam's pods, and its report agrees
//! with itself: the size it names holds and the next one probed does not (or the search hit
//! its cap), every probe's verdict follows from its overruns, body counts follow the layers,
//! and each row has its cost at the common size. Short probes, a generous overrun share:
//! behaviour, not speed (the figures are in BENCHMARKS.md).

use std::path::PathBuf;

use seam_bench::capacity::{self, CapacityPlan, CapacityReport, Probe, Row};

fn grid() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../bench/scenes/grid.toml")
}

fn measure(rows: &[&str], max_layers: u32) -> CapacityReport {
    let plan = CapacityPlan {
        scene: grid(),
        rows: rows.iter().map(|r| Row::parse(r).expect("a row")).collect(),
        ticks: 60,
        rate: 60.0,
        // Half the ticks may overrun: one layer holds on any machine this runs on, and the
        // verdicts are still made by the rule under test.
        max_overrun: 0.5,
        max_layers,
        node_command: vec![env!("CARGO_BIN_EXE_seam-test-node").into()],
    };
    capacity::run(&plan, |probe| eprintln!("{probe:?}")).expect("seam capacity runs")
}

fn probe<'a>(report: &'a CapacityReport, row: &str, layers: u32) -> Option<&'a Probe> {
    report
        .probes
        .iter()
        .find(|p| p.row == row && p.layers == layers)
}

#[test]
fn capacity_finds_a_size_and_its_table_agrees() {
    let report = measure(&["rapier", "apart:2", "seam:2"], 2);
    assert_eq!(report.bodies_per_layer, 2_500);
    assert_eq!(report.rows.len(), 3);
    for probe in &report.probes {
        // Every process holds the rate on its own: the worst one's share decides, and it is
        // at least the share of all the processes' ticks together.
        assert_eq!(
            probe.holds,
            probe.worst_overrun_share <= report.max_overrun,
            "{probe:?}"
        );
        let overall = probe.overruns as f64 / probe.ticks as f64;
        assert!(probe.worst_overrun_share >= overall - 1e-12, "{probe:?}");
        assert_eq!(
            probe.bodies,
            u64::from(probe.layers) * report.bodies_per_layer,
            "the world measured is the size asked for: {probe:?}"
        );
        assert!(probe.wall_p50_ns > 0 && probe.cpu_p50_ns > 0, "{probe:?}");
        assert!(probe.wall_p99_ns >= probe.wall_p50_ns, "{probe:?}");
    }
    for (row, pods) in report.rows.iter().zip([1, 2, 2]) {
        assert!(row.layers >= 1, "{} held not even one layer", row.row);
        let largest = row.at_largest.as_ref().expect("its largest size, measured");
        assert!(largest.holds);
        assert_eq!(largest.layers, row.layers);
        assert_eq!(row.bodies, largest.bodies);
        // Every pod's (and every world's, apart) ticks are counted.
        assert_eq!(largest.ticks, 60 * pods, "{}", row.row);
        assert_eq!(largest.processes, pods, "{}", row.row);
        match probe(&report, &row.row, row.layers + 1) {
            Some(next) => assert!(!row.capped && !next.holds, "{next:?}"),
            None => assert!(row.capped && row.layers == 2, "{row:?}"),
        }
        let common = row.at_common.as_ref().expect("its cost at the common size");
        assert_eq!(common.layers, report.common_layers);
    }
    assert_eq!(report.common_layers, report.rows[0].layers);
    // seam's probes say where its pods' CPU went, phase by phase (plain Rapier's do not):
    // every phase, in order, none negative, Rapier's step above zero; and how much of
    // the narrow phase had a proxy, sampled (in 60 ticks `grid`'s balls may not touch yet).
    for probe in &report.probes {
        if probe.row.starts_with("seam") {
            let names: Vec<&str> = probe.phases_ms.iter().map(|(n, _)| n.as_str()).collect();
            let all: Vec<&str> = seam_proxy::Phase::ALL.iter().map(|p| p.name()).collect();
            assert_eq!(names, all, "{probe:?}");
            assert!(
                probe.phases_ms.iter().all(|(_, ms)| *ms >= 0.0),
                "{probe:?}"
            );
            let step = probe.phases_ms[6].1;
            assert!(step > 0.0, "{probe:?}");
            let (pairs, contacts) = probe.proxy_shares.expect("the narrow phase sampled");
            assert!((0.0..=1.0).contains(&pairs) && (0.0..=1.0).contains(&contacts));
        } else {
            assert!(probe.phases_ms.is_empty() && probe.proxy_shares.is_none());
        }
    }
    // Both forms of the table name every row.
    let text = capacity::document(&report).text();
    for row in &report.rows {
        assert!(text.contains(&row.row), "{text}");
    }
    assert!(text.contains("Where seam's CPU goes"), "{text}");
}

#[test]
fn rows_are_read_or_refused_with_the_choices() {
    assert_eq!(Row::parse("seam:4").expect("a row"), Row::Seam { pods: 4 });
    assert_eq!(
        Row::parse("apart:2").expect("a row"),
        Row::Apart { worlds: 2 }
    );
    for bad in ["seam:0", "seam:x", "apart:0", "apart:", "rapid", ""] {
        let error = Row::parse(bad).expect_err("refused");
        assert!(
            error.contains("rapier, rapier-ed, parallel, parallel-ed, apart:N"),
            "{error}"
        );
    }
}
