//! `seam capacity`: the largest size of a scene that holds its tick rate, for one plain Rapier
//! world and for seam's pods, found by bisection and measured side by side in one run.
//!
//! A size is a number of layers (`Scene::stacked`: every grid entity repeated along y). A row
//! *holds* a size when at most `max_overrun` of its ticks take longer than the period, in every
//! process of its own (each pod, each world apart): pods that hold the rate only on average
//! do not hold it. Rows:
//!
//! - `rapier`, `rapier-ed`: plain Rapier, one thread (`seam-anchor`, without and with
//!   Rapier's `enhanced-determinism`, which seam's worlds have);
//! - `parallel`, `parallel-ed`: plain Rapier with its `parallel` feature, stepping on every
//!   core through rayon (with `enhanced-determinism`, Rapier documents results equal to the
//!   sequential solver's);
//! - `apart:N`: the scene cut as `seam:N` cuts it, each part's bodies a plain one-thread
//!   world in a process of its own, all N stepped at once with nothing crossing between them:
//!   the most a split over N processes could hold on this host if the seam cost nothing (an
//!   upper bound: bodies of different parts never meet);
//! - `seam:N`: the scene as N free-running pods on shared memory (`seam run`), its own
//!   clusters when it has N, else its world cut into N (`Scene::split_into`).
//!
//! Every row runs the scene without its scripted events (blasts, shots, volleys, hand-offs):
//! the plain-Rapier anchor has none, and a seam row that had them would step other physics.
//!
//! Each probe prints what it measured: wall time per tick (the slowest pod's, for seam) and
//! CPU time per tick (the process's for plain Rapier, every thread's; for seam the pods'
//! threads' summed), so contention between pods shows apart from their work. Single worlds
//! are paced at the rate like pods (a tick, then sleep until the next is due).

mod anchor;
mod chart;
mod row;
mod table;

pub use anchor::Build;
pub use chart::draw;
pub use row::{Row, cores, default_rows};
pub use table::document;

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use serde::Serialize;

use crate::error::{BenchError, BenchResult};
use crate::run::{RunPlan, run_pods};

/// The scene's bodies as one plain Rapier world, as the anchor rows step it.
pub fn anchor_world(scene: &crate::scene::Scene) -> BenchResult<seam_anchor::WorldSpec> {
    anchor::world_of(scene)
}

/// What `seam capacity` measures.
#[derive(Debug, Clone)]
pub struct CapacityPlan {
    /// The scene file.
    pub scene: PathBuf,
    /// The rows, in order; the first is what the others are compared with.
    pub rows: Vec<Row>,
    /// Ticks per probe.
    pub ticks: u64,
    /// Ticks per second.
    pub rate: f64,
    /// The largest share of ticks that may overrun the period for a size to hold.
    pub max_overrun: f64,
    /// The most layers tried.
    pub max_layers: u32,
    /// The command that starts a pod (see `RunPlan::node_command`).
    pub node_command: Vec<std::ffi::OsString>,
}

/// One size of one row, measured.
#[derive(Debug, Clone, Serialize)]
pub struct Probe {
    /// The row.
    pub row: String,
    /// Layers of the scene.
    pub layers: u32,
    /// Bodies in the world (every pod's own, for seam).
    pub bodies: u64,
    /// Ticks measured (every pod's, for seam).
    pub ticks: u64,
    /// Ticks longer than the period (every pod's, or every world's, summed).
    pub overruns: u64,
    /// Processes stepping (pods, or plain worlds; 1 for one world).
    pub processes: u64,
    /// The largest share of its own ticks any one process overran in: a size holds when
    /// this is at most `max_overrun`, so every pod (every world) holds the rate on its own.
    pub worst_overrun_share: f64,
    /// Median wall time per tick, ns (the slowest pod's median, for seam).
    pub wall_p50_ns: u64,
    /// 99th percentile wall time per tick, ns (the slowest pod's).
    pub wall_p99_ns: u64,
    /// Median CPU time per tick, ns: the process's (every thread's) for plain Rapier, the
    /// pods' threads' medians summed for seam.
    pub cpu_p50_ns: u64,
    /// Whether the size holds the rate.
    pub holds: bool,
    /// seam: mean thread CPU time per tick of each phase, ms, summed over the pods.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub phases_ms: Vec<(String, f64)>,
    /// seam: the shares of Rapier's narrow-phase pairs, and of contact points, that involve
    /// a proxy (every pod's samples together).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub proxy_shares: Option<(f64, f64)>,
}

/// A row's result.
#[derive(Debug, Clone, Serialize)]
pub struct RowResult {
    /// The row.
    pub row: String,
    /// The largest size that holds (0: not even one layer).
    pub layers: u32,
    /// Its bodies.
    pub bodies: u64,
    /// Whether the search stopped at `max_layers` still holding.
    pub capped: bool,
    /// Its probe at that size.
    pub at_largest: Option<Probe>,
    /// Its probe at the first row's largest size (the common size costs are compared at).
    pub at_common: Option<Probe>,
}

/// Everything `seam capacity` measured.
#[derive(Debug, Clone, Serialize)]
pub struct CapacityReport {
    /// The scene's name.
    pub scene: String,
    /// Ticks per second.
    pub rate: f64,
    /// Ticks per probe.
    pub ticks: u64,
    /// The overrun share allowed.
    pub max_overrun: f64,
    /// Cores of this host.
    pub cores: usize,
    /// Bodies a layer adds (scenery, not stacked, apart).
    pub bodies_per_layer: u64,
    /// The common size, in layers (the first row's largest, at least 1).
    pub common_layers: u32,
    /// Each row's result, in order.
    pub rows: Vec<RowResult>,
    /// Every probe, in the order run.
    pub probes: Vec<Probe>,
}

/// Runs the plan, saying each probe's outcome to `progress`.
pub fn run(plan: &CapacityPlan, mut progress: impl FnMut(&Probe)) -> BenchResult<CapacityReport> {
    let mut scene = crate::scene::load(&plan.scene)?;
    // The plain-Rapier anchor has no scripted events (blasts, shots, volleys, hand-offs), so
    // every row leaves them out and all step the same physics.
    scene.events.clear();
    if !(plan.rate > 0.0 && plan.rate.is_finite()) {
        return Err(BenchError::flag(
            "--rate",
            "must be above 0: capacity is a tick rate held",
        ));
    }
    if !(0.0..1.0).contains(&plan.max_overrun) {
        return Err(BenchError::flag(
            "--max-overrun",
            "must be at least 0 and below 1",
        ));
    }
    let scratch = std::env::temp_dir().join(format!("seam-capacity-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)
        .map_err(|e| BenchError::io("create", scratch.display(), e))?;
    let mut prober = Prober {
        plan,
        scene: &scene,
        scratch: scratch.clone(),
        anchors: Vec::new(),
        probes: Vec::new(),
    };
    let result = search_all(&mut prober, &mut progress);
    let _ = std::fs::remove_dir_all(&scratch);
    let rows = result?;
    let common_layers = rows.first().map_or(1, |r| r.layers.max(1));
    Ok(CapacityReport {
        scene: scene.name.clone(),
        rate: plan.rate,
        ticks: plan.ticks,
        max_overrun: plan.max_overrun,
        cores: cores(),
        bodies_per_layer: scene.clone().stacked(2)?.entity_count()
            - scene.clone().stacked(1)?.entity_count(),
        common_layers,
        rows,
        probes: prober.probes,
    })
}

/// Every row's largest size, then every row at the first row's.
fn search_all(
    prober: &mut Prober<'_>,
    progress: &mut impl FnMut(&Probe),
) -> BenchResult<Vec<RowResult>> {
    let mut rows = Vec::new();
    for &row in &prober.plan.rows {
        let (layers, capped) = largest(prober, row, progress)?;
        rows.push((row, layers, capped));
    }
    let common = rows.first().map_or(1, |&(_, layers, _)| layers.max(1));
    let mut results = Vec::new();
    for (row, layers, capped) in rows {
        let at_common = prober.probe(row, common, progress)?;
        let at_largest = match layers {
            0 => None,
            l => Some(prober.probe(row, l, progress)?),
        };
        results.push(RowResult {
            row: row.label(),
            layers,
            bodies: at_largest.as_ref().map_or(0, |p| p.bodies),
            capped,
            at_largest,
            at_common: Some(at_common),
        });
    }
    Ok(results)
}

/// The largest number of layers `row` holds, by doubling then bisection; and whether the
/// search stopped at `max_layers` still holding.
fn largest(
    prober: &mut Prober<'_>,
    row: Row,
    progress: &mut impl FnMut(&Probe),
) -> BenchResult<(u32, bool)> {
    let max = prober.plan.max_layers.max(1);
    let mut held = 0;
    let mut failed = None;
    let mut layers = 1;
    while failed.is_none() && held < max {
        if prober.probe(row, layers, progress)?.holds {
            held = layers;
            layers = layers.saturating_mul(2).min(max);
        } else {
            failed = Some(layers);
        }
    }
    while let Some(bad) = failed.filter(|&bad| bad - held > 1) {
        let middle = held + (bad - held) / 2;
        if prober.probe(row, middle, progress)?.holds {
            held = middle;
        } else {
            failed = Some(middle);
        }
    }
    Ok((held, failed.is_none()))
}

/// Runs probes, remembering each (a size probed twice is run once).
struct Prober<'a> {
    plan: &'a CapacityPlan,
    scene: &'a crate::scene::Scene,
    scratch: PathBuf,
    anchors: Vec<(Build, PathBuf)>,
    probes: Vec<Probe>,
}

impl Prober<'_> {
    fn probe(
        &mut self,
        row: Row,
        layers: u32,
        progress: &mut impl FnMut(&Probe),
    ) -> BenchResult<Probe> {
        let label = row.label();
        if let Some(done) = self
            .probes
            .iter()
            .find(|p| p.row == label && p.layers == layers)
        {
            return Ok(done.clone());
        }
        let scene = self.scene.clone().stacked(layers)?;
        let mut probe = match row {
            Row::Rapier(build) => {
                self.rapier(build, &[anchor::world_of(&scene)?], scene.entity_count())?
            }
            Row::Apart { worlds } => {
                let plain = Build {
                    parallel: false,
                    determinism: false,
                };
                let apart = anchor::worlds_apart(&scene, worlds)?;
                self.rapier(plain, &apart, scene.entity_count())?
            }
            Row::Seam { pods } => self.seam(pods, &scene, layers)?,
        };
        probe.row = label;
        probe.layers = layers;
        probe.holds = probe.worst_overrun_share <= self.plan.max_overrun;
        progress(&probe);
        self.probes.push(probe.clone());
        Ok(probe)
    }

    /// Plain Rapier built as `build`, stepping `worlds` at once, a process each: the slowest
    /// world's wall times, the worlds' CPU summed, every world's ticks and overruns.
    fn rapier(
        &mut self,
        build: Build,
        worlds: &[seam_anchor::WorldSpec],
        bodies: u64,
    ) -> BenchResult<Probe> {
        let binary = match self.anchors.iter().find(|(b, _)| *b == build) {
            Some((_, path)) => path.clone(),
            None => {
                eprintln!(
                    "seam capacity: building the plain-Rapier anchor ({}) if it is not built",
                    Row::Rapier(build).label()
                );
                let path = anchor::binary(build)?;
                self.anchors.push((build, path.clone()));
                path
            }
        };
        let timings = anchor::run_side_by_side(
            &binary,
            worlds,
            &self.scratch,
            self.plan.ticks,
            self.plan.rate,
        )?;
        let period = (1e9 / self.plan.rate) as u64;
        let walls: Vec<_> = timings.iter().map(|t| summary(&t.wall_ns)).collect();
        let overruns: Vec<(u64, u64)> = timings
            .iter()
            .map(|t| {
                let over = t.wall_ns.iter().filter(|&&ns| ns > period).count();
                (over as u64, t.wall_ns.len() as u64)
            })
            .collect();
        Ok(Probe {
            row: String::new(),
            layers: 0,
            bodies,
            ticks: overruns.iter().map(|&(_, ticks)| ticks).sum(),
            overruns: overruns.iter().map(|&(over, _)| over).sum(),
            processes: overruns.len() as u64,
            worst_overrun_share: worst_share(&overruns),
            wall_p50_ns: walls.iter().map(|w| w.p50_ns).max().unwrap_or(0),
            wall_p99_ns: walls.iter().map(|w| w.p99_ns).max().unwrap_or(0),
            cpu_p50_ns: timings.iter().map(|t| summary(&t.cpu_ns).p50_ns).sum(),
            holds: false,
            phases_ms: Vec::new(),
            proxy_shares: None,
        })
    }

    fn seam(
        &mut self,
        pods: usize,
        scene: &crate::scene::Scene,
        layers: u32,
    ) -> BenchResult<Probe> {
        let split = scene.split_into(pods)?;
        let path = self.scratch.join(format!("scene-{pods}-{layers}.toml"));
        crate::scene::save(&split, &path)?;
        let mut plan = RunPlan::new(&path, "shm");
        plan.node_command.clone_from(&self.plan.node_command);
        plan.ticks = Some(self.plan.ticks);
        plan.rate = self.plan.rate;
        let stop = AtomicBool::new(false);
        let (report, _) = run_pods(&plan, &stop, |_| {})
            .map_err(|e| e.within(format!("{pods} pods at {layers} layers")))?;
        let pods = &report.pods;
        Ok(Probe {
            row: String::new(),
            layers: 0,
            bodies: split.entity_count(),
            ticks: pods.iter().map(|p| p.ticks).sum(),
            overruns: pods.iter().map(|p| p.overruns).sum(),
            processes: pods.len() as u64,
            worst_overrun_share: worst_share(
                &pods
                    .iter()
                    .map(|p| (p.overruns, p.ticks))
                    .collect::<Vec<_>>(),
            ),
            wall_p50_ns: pods.iter().map(|p| p.tick_time.p50_ns).max().unwrap_or(0),
            wall_p99_ns: pods.iter().map(|p| p.tick_time.p99_ns).max().unwrap_or(0),
            cpu_p50_ns: pods.iter().map(|p| p.tick_cpu.p50_ns).sum(),
            holds: false,
            phases_ms: phases_summed(pods),
            proxy_shares: proxy_shares(pods),
        })
    }
}

/// The largest share `overruns / ticks` of the processes' `(overruns, ticks)`; a process that
/// ticked not at all counts as overrunning every tick.
fn worst_share(overruns: &[(u64, u64)]) -> f64 {
    overruns
        .iter()
        .map(|&(over, ticks)| {
            if ticks == 0 {
                1.0
            } else {
                over as f64 / ticks as f64
            }
        })
        .fold(0.0, f64::max)
}

/// Each phase's mean CPU per tick, ms, summed over `pods`.
fn phases_summed(pods: &[crate::run::PodSummary]) -> Vec<(String, f64)> {
    let mut summed: Vec<(String, f64)> = Vec::new();
    for pod in pods {
        for (i, (phase, ms)) in pod.phases_ms.iter().enumerate() {
            match summed.get_mut(i) {
                Some((_, sum)) => *sum += ms,
                None => summed.push((phase.clone(), *ms)),
            }
        }
    }
    summed
}

/// The shares of narrow-phase pairs and of contact points with a proxy, over every pod.
fn proxy_shares(pods: &[crate::run::PodSummary]) -> Option<(f64, f64)> {
    let sum = |f: fn(&crate::node::CensusMean) -> f64| pods.iter().map(|p| f(&p.pairs)).sum();
    let (pairs, contacts): (f64, f64) = (sum(|c| c.pairs), sum(|c| c.contacts));
    let with = |part: f64, whole: f64| if whole > 0.0 { part / whole } else { 0.0 };
    let sampled = pods.iter().any(|p| p.pairs.samples > 0);
    sampled.then(|| {
        (
            with(sum(|c| c.pairs_with_proxy), pairs),
            with(sum(|c| c.contacts_with_proxy), contacts),
        )
    })
}

/// `values` (ns) as the other reports summarise them.
fn summary(values: &[u64]) -> crate::latency::LatencySummary {
    let mut recorder = crate::latency::LatencyRecorder::default();
    for &value in values {
        recorder.record(value);
    }
    recorder.summary()
}
