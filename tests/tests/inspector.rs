//! The inspector in a real browser: a recorded `crossfire` run (real pod processes on shared
//! memory; its runner started near enough the seam for its hand-off to go) loaded in headless
//! Chromium through ChromeDriver, scrubbed to the runner's hand-off,
//! and read back from the page's own state; and the live page while a run goes on.
//!
//! Without Chromium and ChromeDriver (Debian's `chromium`, `chromium-driver`) the browser parts
//! print a skip notice and pass, unless `SEAM_REQUIRE_BROWSER=1` (as `.ci/run` sets), under
//! which they fail.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use seam_bench::inspect::browser::{self, Browser};
use seam_bench::inspect::{LiveRecording, PageMode, Served, Server, page};
use seam_bench::record::{Chunk, PartsDir, Recording};
use seam_bench::run::{self, RunPlan};
use seam_tests::TestContext;
use serde_json::json;

fn scene(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../bench/scenes")
        .join(format!("{name}.toml"))
}

fn out_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::create_dir_all(&dir).expect("test output folder");
    dir
}

/// Whether the browser is here; a skip notice if not, a failure if it is required.
fn browser_here() -> bool {
    match browser::binaries() {
        Ok(_) => true,
        Err(e) if std::env::var("SEAM_REQUIRE_BROWSER").as_deref() == Ok("1") => {
            panic!("SEAM_REQUIRE_BROWSER=1 but {e}")
        }
        Err(e) => {
            eprintln!("SKIP: {e}; set SEAM_REQUIRE_BROWSER=1 to fail instead");
            false
        }
    }
}

/// `variants/crossfire-handoff` (crossfire with its runner near enough the seam for its
/// scripted hand-off to go) as two pods on this test's shared memory, faster than real time,
/// each pod recording its stream into `parts`.
fn crossfire_plan(parts: &Path) -> (TestContext, RunPlan) {
    let ctx = TestContext::new(seam_transport::Backend::Shm).expect("shm is always here");
    let plan = RunPlan {
        rate: 300.0,
        ticks: Some(600),
        node_command: vec![env!("CARGO_BIN_EXE_seam-test-node").into()],
        start_delay: Duration::from_millis(500),
        record_dir: Some(parts.to_owned()),
        ..RunPlan::new(scene("variants/crossfire-handoff"), ctx.url())
    };
    (ctx, plan)
}

fn record_crossfire(out: &Path) -> Recording {
    let parts = PartsDir::beside(Some(out)).expect("parts folder");
    let (_ctx, plan) = crossfire_plan(&parts.dir);
    let report = run::run(&plan, &AtomicBool::new(false), |_| {}).expect("crossfire runs");
    assert!(
        report.ownership.holds(),
        "{}",
        run::document(&report).text()
    );
    let summary = parts
        .merge_into(out, &[], "seam run")
        .expect("the parts merge");
    assert_eq!(summary.parts, 2, "one part per pod");
    assert_eq!(summary.cut_short, 0);
    Recording::read(out).expect("the recording reads back")
}

#[test]
fn a_recorded_run_has_every_tick_of_both_pods_and_the_runners_handoff() {
    let dir = out_dir("inspector-recording");
    let recording = record_crossfire(&dir.join("crossfire.rec"));
    let header = &recording.header;
    assert_eq!(header.streams, ["west", "east"]);
    for stream in 0..2u16 {
        let ticks: Vec<u64> = recording.stream_ticks(stream).map(|t| t.tick).collect();
        assert_eq!(ticks, (1..=600).collect::<Vec<u64>>(), "stream {stream}");
    }
    // The scripted hand-off at tick 300: west gives the runner, east takes it.
    let runner = header.entity_index("runner").expect("runner");
    let sides: Vec<(u16, u64, bool)> = recording
        .chunks
        .iter()
        .filter_map(|c| match c {
            Chunk::Tick(t) => Some(t),
            Chunk::Fault(_) => None,
        })
        .flat_map(|t| {
            t.handoffs
                .iter()
                .filter(|h| h.entity == runner)
                .map(move |h| (t.stream, t.tick, h.taken))
        })
        .collect();
    assert!(
        sides
            .iter()
            .any(|&(s, t, taken)| s == 0 && !taken && t >= 300),
        "west never gave the runner: {sides:?}"
    );
    assert!(
        sides
            .iter()
            .any(|&(s, t, taken)| s == 1 && taken && t >= 300),
        "east never took the runner: {sides:?}"
    );
    assert_eq!(recording.owner_at(runner, 1), Some(0));
    // Routed ops (the explosion's pushes on east's crates) were recorded where they landed.
    let ops: usize = recording.stream_ticks(1).map(|t| t.ops.len()).sum();
    assert!(ops > 0, "no routed op recorded on east");
}

/// The page `seam inspect` writes for the recording at `rec` (beside it, `.html`), open in a
/// fresh headless Chromium once it has loaded or thrown.
fn open_page(rec: &Path) -> Browser {
    let bytes = std::fs::read(rec).expect("recording");
    let html = rec.with_extension("html");
    std::fs::write(&html, page(PageMode::Embedded(&bytes))).expect("page");
    let browser = Browser::start().expect("headless chromium");
    browser
        .goto(&format!("file://{}", html.display()))
        .expect("page loads");
    browser
        .wait_for(
            "window.seam && (seam.ready || seam.errors.length > 0)",
            Duration::from_secs(60),
        )
        .expect("the page finishes loading");
    browser
}

#[test]
fn the_page_in_chromium_shows_the_runners_owner_change() {
    if !browser_here() {
        return;
    }
    let dir = out_dir("inspector-page");
    let rec = dir.join("crossfire.rec");
    let recording = record_crossfire(&rec);
    let browser = open_page(&rec);
    let errors = browser.eval("return seam.errors;").expect("errors");
    assert_eq!(errors, json!([]), "the page threw");
    let ticks = browser.eval("return seam.ticks.length;").expect("ticks");
    assert_eq!(ticks, json!(600));

    // Scrub to the runner's hand-off as the page found it.
    let handoff = browser
        .eval(
            "const h = seam.handoffs.find(h => h.name === 'runner' && h.to === 'east'); \
             return h ? { tick: h.tick, from: h.from } : null;",
        )
        .expect("hand-offs");
    let tick = handoff["tick"]
        .as_u64()
        .unwrap_or_else(|| panic!("the page found no hand-off of the runner to east: {handoff}"));
    assert_eq!(handoff["from"], json!("west"));
    let shown = browser
        .eval(&format!("return seam.seek({tick});"))
        .expect("seek");
    assert_eq!(shown, json!(tick), "the page did not scrub to the hand-off");
    // Before it (and before any tick in transit, owned by nobody), west owned it.
    let owner_before = browser
        .eval(&format!(
            "for (let t = {tick} - 1; t > 0; t--) {{ const o = seam.ownerOf('runner', t); \
             if (o) return [t, o]; }} return null;"
        ))
        .expect("owner");
    assert_eq!(owner_before[1], json!("west"), "{owner_before}");
    let before = owner_before[0].as_u64().unwrap_or(0);
    let selection = browser
        .eval("return seam.select('runner');")
        .expect("select");
    let owners: Vec<String> = selection["owners"]
        .as_array()
        .unwrap_or_else(|| panic!("no owners in {selection}"))
        .iter()
        .map(|o| o["owner"].as_str().unwrap_or("").to_owned())
        .collect();
    let changed = owners.windows(2).any(|w| w[0] == "west" && w[1] == "east");
    assert!(changed, "the runner's owners in the page: {owners:?}");
    // The page agrees with the file on who owns it before the hand-off.
    let runner = recording.header.entity_index("runner").expect("runner");
    assert_eq!(recording.owner_at(runner, before), Some(0));

    // Step and play a little: nothing throws.
    browser
        .eval("document.getElementById('fwd').click(); document.getElementById('back').click(); return 0;")
        .expect("step");
    let fps = browser
        .eval("return seam.measureScrub(200);")
        .expect("scrub")
        .as_f64()
        .unwrap_or(0.0);
    assert!(fps > 0.0);
    let load = browser.eval("return seam.loadMs;").expect("load");
    eprintln!("crossfire page: loaded in {load} ms, scrubbed at {fps:.0} ticks/s");
    browser
        .eval(&format!("return seam.seek({tick});"))
        .expect("seek");
    let shot = dir.join("crossfire-handoff.png");
    browser.screenshot(&shot).expect("screenshot");
    assert!(std::fs::metadata(&shot).map(|m| m.len()).unwrap_or(0) > 1000);
    let errors = browser.eval("return seam.errors;").expect("errors");
    assert_eq!(errors, json!([]), "the page threw");
}

fn get(url_base: &str, path: &str) -> (String, Vec<u8>) {
    let addr = url_base.trim_start_matches("http://").trim_end_matches('/');
    let mut stream = std::net::TcpStream::connect(addr).expect("server answers");
    write!(stream, "GET {path} HTTP/1.1\r\nhost: {addr}\r\n\r\n").expect("request");
    let mut answer = Vec::new();
    stream.read_to_end(&mut answer).expect("answer");
    let split = answer
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("HTTP head");
    (
        String::from_utf8_lossy(&answer[..split]).into_owned(),
        answer[split + 4..].to_vec(),
    )
}

#[test]
fn the_live_page_follows_a_run_as_it_goes() {
    let dir = out_dir("inspector-live");
    let parts = PartsDir::beside(Some(&dir.join("live.rec"))).expect("parts folder");
    let (_ctx, plan) = crossfire_plan(&parts.dir);
    let live = LiveRecording::watch(&parts.dir);
    let server = Server::start("127.0.0.1:0", Served::Live(live.clone())).expect("server");
    let url = server.url();
    let (head, html) = get(&url, "/");
    assert!(head.starts_with("HTTP/1.1 200"), "{head}");
    assert!(String::from_utf8_lossy(&html).contains(r#"const MODE = "live";"#));

    let watcher = {
        let url = url.clone();
        std::thread::spawn(move || {
            // Sizes of the live recording seen while the run goes on.
            let mut sizes = Vec::new();
            let until = Instant::now() + Duration::from_secs(30);
            while Instant::now() < until {
                let (head, body) = get(&url, "/recording?from=0");
                sizes.push(body.len());
                if head.contains("x-seam-done: 1") {
                    break;
                }
                std::thread::sleep(Duration::from_millis(200));
            }
            sizes
        })
    };
    let browser = if browser_here() {
        let b = Browser::start().expect("headless chromium");
        b.goto(&url).expect("live page loads");
        Some(b)
    } else {
        None
    };
    let report = run::run(&plan, &AtomicBool::new(false), |_| {}).expect("crossfire runs");
    assert!(report.ownership.holds());
    if let Some(b) = &browser {
        // The page saw ticks while the pods ran.
        b.wait_for("window.seam && seam.ready", Duration::from_secs(10))
            .expect("the live page shows ticks");
        let errors = b.eval("return seam.errors;").expect("errors");
        assert_eq!(errors, json!([]), "the live page threw");
    }
    live.finish(&parts.dir);
    let sizes = watcher.join().expect("watcher");
    let growing = sizes.windows(2).filter(|w| w[1] > w[0]).count();
    assert!(
        growing >= 2,
        "the live recording did not grow while the run went on: {sizes:?}"
    );
    let (_, whole) = get(&url, "/recording?from=0");
    let recording = Recording::parse(&whole).expect("the live recording parses");
    assert_eq!(
        recording.stream_ticks(0).count(),
        600,
        "the live recording has every tick of west once the run is over"
    );
    assert!(live.problem().is_none(), "{:?}", live.problem());
}

/// Where an entity's owner had it at a tick, and where the single world had it.
type SplitAndTruth = (Option<[f32; 3]>, Option<[f32; 3]>);

/// Largest distance between entity `index`'s owner's pose and its single-world copy, m.
fn largest_error(recording: &Recording, index: u32) -> f64 {
    let reference = recording
        .header
        .reference_stream()
        .expect("a reference stream");
    let mut at_tick: std::collections::BTreeMap<u64, SplitAndTruth> = Default::default();
    for chunk in &recording.chunks {
        let Chunk::Tick(t) = chunk else { continue };
        let Ok(i) = t.owned.binary_search_by_key(&index, |p| p.entity) else {
            continue;
        };
        let entry = at_tick.entry(t.tick).or_default();
        if t.stream == reference {
            entry.1 = Some(t.owned[i].position());
        } else {
            entry.0 = Some(t.owned[i].position());
        }
    }
    at_tick
        .values()
        .filter_map(|(split, truth)| {
            let (s, r) = ((*split)?, (*truth)?);
            Some(
                s.iter()
                    .zip(r)
                    .map(|(a, b)| f64::from(a - b).powi(2))
                    .sum::<f64>()
                    .sqrt(),
            )
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_compare_recording_carries_the_single_world_and_the_page_reads_its_error() {
    let dir = out_dir("inspector-compare");
    let out = dir.join("crossfire-compare.rec");
    let scene = seam_bench::scene::load(&scene("crossfire")).expect("scene");
    let settings = seam_bench::accuracy::TrialSettings::default();
    let result = seam_bench::accuracy::run_recorded_trial(&scene, &settings, None, Some(&out))
        .expect("the trial runs");
    let recording = Recording::read(&out).expect("the recording reads back");
    assert_eq!(recording.header.streams, ["west", "east", "reference"]);
    assert_eq!(recording.stream_ticks(2).count() as u64, scene.ticks);
    // The recording's largest error over the scene's bodies is the comparison's largest error,
    // to the millimetre the format keeps.
    let dynamic: Vec<u32> = recording
        .header
        .groups
        .iter()
        .filter(|g| g.role == "dynamic")
        .flat_map(|g| g.first..g.first + g.copies)
        .collect();
    let (worst, worst_error) = dynamic
        .iter()
        .map(|&e| (e, largest_error(&recording, e)))
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    assert!(
        (worst_error - result.accuracy.position_max_m).abs() < 0.005,
        "recording {worst_error} m against compare {} m",
        result.accuracy.position_max_m
    );
    if !browser_here() {
        return;
    }
    let browser = open_page(&out);
    let name = recording.header.entity_name(worst);
    let selection = browser
        .eval(&format!("return seam.select({});", json!(name)))
        .expect("select");
    let page_error = selection["error_max_m"].as_f64().unwrap_or(f64::NAN);
    assert!(
        (page_error - worst_error).abs() < 1e-3,
        "{name}: the page says {page_error} m, the file {worst_error} m"
    );
    assert_eq!(
        browser.eval("return seam.errors;").expect("errors"),
        json!([])
    );
}
