//! What each `seam` command does beyond calling its module: finding this executable for the
//! pods, progress on stderr, printing what was measured, and the exit status.

use seam_bench::accuracy::{self, TrialSettings};
use seam_bench::chaos::ChaosPlan;
use seam_bench::console::Progress;
use seam_bench::node;
use seam_bench::run::{self, RunPlan};

use crate::cli::Output;

/// `seam compare`: one trial per scene; with `--markdown`, one table with a row each.
pub(crate) fn compare(
    scenes: &[std::path::PathBuf],
    settings: &TrialSettings,
    trace: Option<&str>,
    output: Output,
) -> Result<(), String> {
    let mut results = Vec::new();
    let mut progress = Progress::new(Some(scenes.len() as u64));
    for path in scenes {
        progress.status(&format!("{}: split and one world", path.display()));
        let scene = seam_bench::scene::load(path).map_err(|e| e.to_string())?;
        let result = accuracy::run_trial(&scene, settings, &run::fresh_run_id(), trace)?;
        progress.step(&path.display().to_string());
        if output.json {
            println!(
                "{}",
                serde_json::to_string_pretty(&result).expect("results serialise")
            );
        } else if !output.markdown {
            print!("{}", accuracy::table(&result));
        }
        results.push(result);
    }
    if output.markdown {
        print!("{}", accuracy::markdown(&results));
    }
    Ok(())
}

/// `seam sweep`.
pub(crate) fn sweep(
    scenes: Vec<std::path::PathBuf>,
    quick: bool,
    ticks: Option<u64>,
    transports: Vec<String>,
    rate: f64,
    out: &std::path::Path,
) -> Result<(), String> {
    let paths = if scenes.is_empty() {
        [
            "gallery",
            "corridor",
            "stacks",
            "light-on-heavy",
            "equal-masses",
            "seam-stack",
            "grid",
            "crossfire",
        ]
        .iter()
        .map(|name| format!("bench/scenes/{name}.toml").into())
        .collect()
    } else {
        scenes
    };
    let scenes = load_scenes(paths)?;
    let mut grid = if quick {
        seam_bench::sweep::SweepGrid::quick()
    } else {
        seam_bench::sweep::SweepGrid::full()
    };
    for transport in transports
        .iter()
        .filter(|t| t.as_str() != "none")
        .map(|t| expand_transport(t))
    {
        match seam_transport::open(&transport) {
            Ok(_) => grid.transports.push(transport),
            Err(e) => tracing::warn!("seam sweep: leaving out the transport axis on {e}"),
        }
    }
    let free = accuracy::FreeRunning {
        rate,
        node_command: node_command()?,
        hosts: seam_bench::run::HostsPlan::default(),
        in_phase: false,
    };
    let mut progress = None;
    let results = seam_bench::sweep::run(&scenes, &grid, ticks, &free, |_, total, line| {
        progress
            .get_or_insert_with(|| Progress::new(Some(total as u64)))
            .step(line);
    })?;
    drop(progress);
    for path in seam_bench::sweep::write(&results, out)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// `redis` alone is shorthand for the local default server.
pub(crate) fn expand_transport(name: &str) -> String {
    match name {
        "redis" => "redis://127.0.0.1:6379".to_owned(),
        other => other.to_owned(),
    }
}

/// Progress through `total` rows, one step per row (see [`Progress`]).
pub(crate) fn progress(total: usize) -> impl FnMut(&str) {
    let mut progress = Progress::new(Some(total as u64));
    move |row| progress.step(row)
}

/// How `seam run`, `chaos` and `sweep` start a pod: this executable's `node` command.
fn node_command() -> Result<Vec<std::ffi::OsString>, String> {
    let exe = std::env::current_exe().map_err(|e| format!("cannot find seam itself: {e}"))?;
    Ok(vec![exe.into(), "node".into()])
}

/// `seam run`: this executable starts the pods.
pub(crate) fn run_scene(mut plan: RunPlan) -> Result<run::RunReport, String> {
    plan.node_command = node_command()?;
    let stop = node::stop_flag()?;
    eprintln!(
        "seam run: {} on {}, one pod per cluster",
        plan.scene.display(),
        seam_transport::redact_url(&plan.transport)
    );
    let shown = Progress::new(None);
    run::run(&plan, &stop, |progress| {
        let pods: Vec<String> = progress
            .pods
            .iter()
            .flatten()
            .map(|p| p.to_string())
            .collect();
        let pods = if pods.is_empty() {
            "starting".to_owned()
        } else {
            pods.join(" · ")
        };
        shown.status(&format!("[{:5.1} s] {pods}", progress.elapsed_s));
    })
}

/// `value` seconds (clap has checked it is a number; negative or not finite becomes 0, which
/// the caller refuses).
pub(crate) fn seconds(value: f64) -> std::time::Duration {
    std::time::Duration::try_from_secs_f64(value).unwrap_or_default()
}

pub(crate) fn chaos(mut plan: ChaosPlan, output: Output) -> Result<(), String> {
    if plan.duration < std::time::Duration::from_secs(10) {
        return Err("--duration-s must be at least 10".into());
    }
    if plan.fault_every < std::time::Duration::from_secs(2) {
        return Err("--fault-every-s must be at least 2 (a fault needs its quiet second)".into());
    }
    plan.node_command = node_command()?;
    let stop = node::stop_flag()?;
    eprintln!(
        "seam chaos: {} for {:.0} s, a fault every {:.0} s",
        plan.scene.display(),
        plan.duration.as_secs_f64(),
        plan.fault_every.as_secs_f64()
    );
    let progress = Progress::new(None);
    let report = seam_bench::chaos::run(&plan, &stop, |line| progress.status(line))?;
    drop(progress);
    output.report(
        &report,
        seam_bench::chaos::table,
        seam_bench::chaos::markdown,
    );
    if report.holds() {
        Ok(())
    } else {
        Err("seam chaos: a target did not hold (see the report)".into())
    }
}

/// `seam network`: accuracy against a simulated delay between two hosts.
#[allow(clippy::too_many_arguments)]
pub(crate) fn network(
    scenes: Vec<std::path::PathBuf>,
    delays_ms: Vec<f64>,
    jitter_ms: f64,
    rate: f64,
    in_phase: bool,
    redis: &str,
    out: &std::path::Path,
) -> Result<(), String> {
    if delays_ms.iter().any(|d| !d.is_finite() || *d < 0.0)
        || !jitter_ms.is_finite()
        || jitter_ms < 0.0
    {
        return Err("--delays-ms and --jitter-ms must be non-negative numbers".into());
    }
    let paths: Vec<std::path::PathBuf> = if scenes.is_empty() {
        ["crossfire", "gallery"]
            .iter()
            .map(|name| format!("bench/scenes/{name}.toml").into())
            .collect()
    } else {
        scenes
    };
    let scenes = load_scenes(paths)?;
    let plan = seam_bench::network::NetworkPlan {
        scenes,
        delays_ms,
        jitter_ms,
        rate,
        in_phase,
        redis: expand_transport(redis),
        node_command: node_command()?,
    };
    let mut progress = None;
    let trials = seam_bench::network::run(&plan, |_, total, line| {
        progress
            .get_or_insert_with(|| Progress::new(Some(total as u64)))
            .step(line);
    })?;
    drop(progress);
    print!("{}", seam_bench::network::table(&trials));
    for path in seam_bench::network::write(&trials, out)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// Loads each scene file, kept with its path.
fn load_scenes(
    paths: Vec<std::path::PathBuf>,
) -> Result<Vec<(std::path::PathBuf, seam_bench::scene::Scene)>, String> {
    paths
        .into_iter()
        .map(|p| {
            seam_bench::scene::load(&p)
                .map(|scene| (p, scene))
                .map_err(|e| format!("{e} (run from the repository root, or pass --scene FILE)"))
        })
        .collect()
}
