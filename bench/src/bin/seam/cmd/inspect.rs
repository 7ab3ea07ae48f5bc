//! `seam inspect`: a recording as a page to scrub through, a still, or the page's own timings.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use seam_bench::error::{BenchError, BenchResult, Context};
use seam_bench::inspect::{PageMode, Served, Server, StillOptions, browser, page, render_still};
use seam_bench::node;
use seam_bench::record::{Chunk, Recording};

/// `seam inspect`'s flags.
#[derive(clap::Args)]
pub(crate) struct InspectArgs {
    /// The recording.
    file: PathBuf,
    /// Where to write the page (default: FILE.html).
    #[arg(long, value_name = "PAGE")]
    out: Option<PathBuf>,
    /// Serve the page on loopback (see --addr) until Ctrl-C instead of writing it.
    #[arg(long)]
    serve: bool,
    /// Where --serve and --measure listen (port 0: any free port).
    #[arg(long, default_value = "127.0.0.1:0", value_name = "ADDR")]
    addr: String,
    /// Draw the view at --tick into this PNG instead.
    #[arg(long, value_name = "PNG")]
    png: Option<PathBuf>,
    /// The tick a still shows (the first recorded at or after it).
    #[arg(long, default_value_t = 0)]
    tick: u64,
    /// In a still, outline this cluster's proxies in their owners' colours.
    #[arg(long, value_name = "CLUSTER")]
    world: Option<String>,
    /// A still's size, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "1200x800")]
    size: String,
    /// Load the page in headless Chromium (Debian's chromium and chromium-driver) and
    /// print what it measured of itself: load time and random-tick scrub rate.
    #[arg(long)]
    measure: bool,
    /// Ticks --measure draws back to back.
    #[arg(long, default_value_t = 300)]
    frames: u32,
}

/// Reads the recording (a bad file is an error here, on the console, rather than in the page),
/// then does what the flags ask: a still, a measurement, a served page, or a page file.
pub(crate) fn main(args: &InspectArgs) -> BenchResult<()> {
    let shown = args.file.display();
    let bytes = std::fs::read(&args.file).map_err(|e| BenchError::io("read", &shown, e))?;
    let recording = Recording::parse(&bytes).context(&shown)?;
    if recording.cut_short {
        eprintln!(
            "seam inspect: {shown} ends inside a chunk; the whole chunks before it are shown"
        );
    }
    if let Some(png) = &args.png {
        still(args, &recording, png)
    } else if args.measure {
        measure(args, bytes)
    } else if args.serve {
        serve(&args.addr, bytes)
    } else {
        write_page(args, &recording, &bytes)
    }
}

/// The view at `--tick` as a PNG.
fn still(args: &InspectArgs, recording: &Recording, png: &Path) -> BenchResult<()> {
    let size = args
        .size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| (64..=8192).contains(&w) && (64..=8192).contains(&h))
        .ok_or_else(|| {
            BenchError::flag(
                "--size",
                format!("{:?}: WIDTHxHEIGHT, 64 to 8192 each", args.size),
            )
        })?;
    let world = match &args.world {
        Some(name) => {
            let streams = &recording.header.streams;
            let index = streams.iter().position(|s| s == name).ok_or_else(|| {
                BenchError::flag(
                    "--world",
                    format!(
                        "{name:?}: the recording's clusters are {}",
                        streams.join(", ")
                    ),
                )
            })?;
            Some(index as u16)
        }
        None => None,
    };
    let options = StillOptions {
        tick: args.tick,
        size,
        world,
    };
    let drawn = render_still(recording, &options, png)?;
    eprintln!("seam inspect: tick {drawn} -> {}", png.display());
    Ok(())
}

/// The page as `seam inspect FILE` writes it (the recording inside), then as `--serve` serves
/// it (fetched), each loaded in headless Chromium; fails if the page threw.
fn measure(args: &InspectArgs, bytes: Vec<u8>) -> BenchResult<()> {
    let file = std::env::temp_dir().join(format!("seam-measure-{}.html", std::process::id()));
    std::fs::write(&file, page(PageMode::Embedded(&bytes)))
        .map_err(|e| BenchError::io("write", file.display(), e))?;
    let embedded = browser::measure(&format!("file://{}", file.display()), args.frames);
    let _ = std::fs::remove_file(&file);
    let server = Server::start(&args.addr, Served::Recording(Arc::new(bytes)))?;
    let fetched = browser::measure(&server.url(), args.frames);
    let mut threw = false;
    for (how, figures) in [("page file", embedded?), ("served page", fetched?)] {
        threw |= !figures.errors.is_empty();
        let errors = if figures.errors.is_empty() {
            String::new()
        } else {
            format!("; page errors: {}", figures.errors.join("; "))
        };
        println!(
            "{}: {how}: {} ticks, {} hand-offs; loaded in {:.0} ms, scrubbed at {:.0} ticks/s ({} drawn){errors}",
            args.file.display(),
            figures.ticks,
            figures.handoffs,
            figures.load_ms,
            figures.scrub_fps,
            args.frames,
        );
    }
    if threw {
        Err(BenchError::Failed("the page threw (above)".to_owned()))
    } else {
        Ok(())
    }
}

/// The page on loopback until Ctrl-C.
fn serve(addr: &str, bytes: Vec<u8>) -> BenchResult<()> {
    let server = Server::start(addr, Served::Recording(Arc::new(bytes)))?;
    eprintln!("seam inspect: {} (Ctrl-C to stop)", server.url());
    let stop = node::stop_flag()?;
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(100));
    }
    Ok(())
}

/// One self-contained page, FILE.html unless `--out` says where.
fn write_page(args: &InspectArgs, recording: &Recording, bytes: &[u8]) -> BenchResult<()> {
    let out = args.out.clone().unwrap_or_else(|| {
        let mut name = args.file.as_os_str().to_owned();
        name.push(".html");
        name.into()
    });
    std::fs::write(&out, page(PageMode::Embedded(bytes)))
        .map_err(|e| BenchError::io("write", out.display(), e))?;
    eprintln!(
        "seam inspect: {} ticks of {} -> {} (open it in a browser)",
        recording.chunks.iter().map(Chunk::tick).max().unwrap_or(0),
        recording.header.scene,
        out.display()
    );
    Ok(())
}
