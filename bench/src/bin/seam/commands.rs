//! What each `seam` command does beyond calling its module: finding this executable for the
//! pods, progress on stderr, printing what was measured, and the exit status.

use seam_bench::accuracy::{self, TrialSettings};
use seam_bench::chaos::ChaosPlan;
use seam_bench::console::Progress;
use seam_bench::node;
use seam_bench::run::{self, RunPlan};

use crate::cli::{InspectArgs, Output, RecordArgs};
use seam_bench::inspect::{LiveRecording, Served, Server};
use seam_bench::record::PartsDir;
use std::path::Path;

/// `seam compare`: one trial per scene; with `--markdown`, one table with a row each.
pub(crate) fn compare(
    scenes: &[std::path::PathBuf],
    settings: &TrialSettings,
    trace: Option<&str>,
    record: Option<&Path>,
    output: Output,
) -> Result<(), String> {
    if record.is_some() && scenes.len() != 1 {
        return Err("--record writes one recording: give one scene".into());
    }
    let mut results = Vec::new();
    let mut progress = Progress::new(Some(scenes.len() as u64));
    for path in scenes {
        progress.status(&format!("{}: split and one world", path.display()));
        let scene = seam_bench::scene::load(path).map_err(|e| e.to_string())?;
        let result = accuracy::run_recorded_trial(&scene, settings, trace, record)?;
        if let Some(out) = record {
            let size = std::fs::metadata(out).map(|m| m.len()).unwrap_or(0);
            eprintln!(
                "seam compare: recorded the split run and the single world: {:.1} MB -> {}",
                size as f64 / 1e6,
                out.display()
            );
        }
        progress.step(&path.display().to_string());
        if output.json {
            println!(
                "{}",
                serde_json::to_string_pretty(&result).expect("results serialise")
            );
        }
        results.push(result);
    }
    if !output.json {
        output.print(&accuracy::document(&results));
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
pub(crate) fn run_scene(mut plan: RunPlan, record: &RecordArgs) -> Result<run::RunReport, String> {
    plan.node_command = node_command()?;
    let stop = node::stop_flag()?;
    eprintln!(
        "seam run: {} on {}, one pod per cluster",
        plan.scene.display(),
        seam_transport::redact_url(&plan.transport)
    );
    let parts = if record.record.is_some() || record.inspect {
        Some(PartsDir::beside(record.record.as_deref()).map_err(|e| e.to_string())?)
    } else {
        None
    };
    plan.record_dir = parts.as_ref().map(|p| p.dir.clone());
    let live = match (&parts, record.inspect) {
        (Some(parts), true) => {
            let live = LiveRecording::watch(&parts.dir);
            let server = Server::start(&record.inspect_addr, Served::Live(live.clone()))?;
            eprintln!("seam run: inspector at {}", server.url());
            Some((live, server))
        }
        _ => None,
    };
    let report = run_pods_shown(&plan, &stop);
    if let (Some((live, _server)), Some(parts)) = (&live, &parts) {
        live.finish(&parts.dir);
        if let Some(problem) = live.problem() {
            eprintln!("seam run: inspector: {problem}");
        }
    }
    if let (Some(parts), Some(out)) = (&parts, &record.record) {
        // Even a failed run's recording is worth keeping: it shows what went wrong.
        match parts.merge_into(out, &[], "seam run") {
            Ok(summary) => eprintln!("seam run: {}", summary.line(out)),
            Err(e) => eprintln!("seam run: cannot write {}: {e}", out.display()),
        }
    }
    report
}

/// `seam run`'s pods, with progress on the console.
fn run_pods_shown(
    plan: &RunPlan,
    stop: &std::sync::atomic::AtomicBool,
) -> Result<run::RunReport, String> {
    let shown = Progress::new(None);
    run::run(plan, stop, |progress| {
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

pub(crate) fn chaos(
    mut plan: ChaosPlan,
    record: Option<&Path>,
    output: Output,
) -> Result<(), String> {
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
    let parts = match record {
        Some(out) => Some(PartsDir::beside(Some(out)).map_err(|e| e.to_string())?),
        None => None,
    };
    plan.record_dir = parts.as_ref().map(|p| p.dir.clone());
    let progress = Progress::new(None);
    let report = seam_bench::chaos::run(&plan, &stop, |line| progress.status(line))?;
    drop(progress);
    if let (Some(parts), Some(out)) = (&parts, record) {
        let summary = parts
            .merge_into(out, &report.fault_log, "seam chaos")
            .map_err(|e| format!("cannot write {}: {e}", out.display()))?;
        eprintln!("seam chaos: {}", summary.line(out));
    }
    output.report(&report, seam_bench::chaos::document);
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
    print!("{}", seam_bench::network::document(&trials).text());
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

/// `seam inspect`.
pub(crate) fn inspect(plan: &InspectArgs) -> Result<(), String> {
    use seam_bench::inspect::{PageMode, StillOptions, browser, page, render_still};
    use seam_bench::record::Recording;
    let shown = plan.file.display();
    let bytes = std::fs::read(&plan.file).map_err(|e| format!("cannot read {shown}: {e}"))?;
    // Read it here first, so a bad file is an error on the console rather than in the page.
    let recording = Recording::parse(&bytes).map_err(|e| format!("{shown}: {e}"))?;
    if recording.cut_short {
        eprintln!(
            "seam inspect: {shown} ends inside a chunk; the whole chunks before it are shown"
        );
    }
    if let Some(png) = &plan.png {
        let (w, h) = plan
            .size
            .split_once('x')
            .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
            .filter(|&(w, h)| (64..=8192).contains(&w) && (64..=8192).contains(&h))
            .ok_or_else(|| format!("--size {:?}: WIDTHxHEIGHT, 64 to 8192 each", plan.size))?;
        let world = match &plan.world {
            Some(name) => Some(
                recording
                    .header
                    .streams
                    .iter()
                    .position(|s| s == name)
                    .ok_or_else(|| {
                        format!(
                            "--world {name:?}: the recording's clusters are {}",
                            recording.header.streams.join(", ")
                        )
                    })? as u16,
            ),
            None => None,
        };
        let options = StillOptions {
            tick: plan.tick,
            size: (w, h),
            world,
        };
        let drawn = render_still(&recording, &options, png)?;
        eprintln!("seam inspect: tick {drawn} -> {}", png.display());
        return Ok(());
    }
    if plan.measure {
        // The page as `seam inspect FILE` writes it (the recording inside), then as `--serve`
        // serves it (fetched).
        let file = std::env::temp_dir().join(format!("seam-measure-{}.html", std::process::id()));
        std::fs::write(&file, page(PageMode::Embedded(&bytes)))
            .map_err(|e| format!("cannot write {}: {e}", file.display()))?;
        let embedded = browser::measure(&format!("file://{}", file.display()), plan.frames);
        let _ = std::fs::remove_file(&file);
        let server = Server::start(&plan.addr, Served::Recording(std::sync::Arc::new(bytes)))?;
        let fetched = browser::measure(&server.url(), plan.frames);
        let mut threw = false;
        for (how, figures) in [("page file", embedded?), ("served page", fetched?)] {
            threw |= !figures.errors.is_empty();
            println!(
                "{shown}: {how}: {} ticks, {} hand-offs; loaded in {:.0} ms, scrubbed at {:.0} ticks/s ({} drawn){}",
                figures.ticks,
                figures.handoffs,
                figures.load_ms,
                figures.scrub_fps,
                plan.frames,
                if figures.errors.is_empty() {
                    String::new()
                } else {
                    format!("; page errors: {}", figures.errors.join("; "))
                }
            );
        }
        return if threw {
            Err("the page threw (above)".into())
        } else {
            Ok(())
        };
    }
    if plan.serve {
        let server = Server::start(&plan.addr, Served::Recording(std::sync::Arc::new(bytes)))?;
        eprintln!("seam inspect: {} (Ctrl-C to stop)", server.url());
        let stop = node::stop_flag()?;
        while !stop.load(std::sync::atomic::Ordering::Relaxed) {
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        return Ok(());
    }
    let out = plan.out.clone().unwrap_or_else(|| {
        let mut name = plan.file.as_os_str().to_owned();
        name.push(".html");
        name.into()
    });
    std::fs::write(&out, page(PageMode::Embedded(&bytes)))
        .map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    eprintln!(
        "seam inspect: {} ticks of {} -> {} (open it in a browser)",
        recording
            .chunks
            .iter()
            .map(seam_bench::record::Chunk::tick)
            .max()
            .unwrap_or(0),
        recording.header.scene,
        out.display()
    );
    Ok(())
}
