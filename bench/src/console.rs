//! What `seam` writes to stderr: log lines through `tracing`, and progress.
//!
//! Logs are filtered by `RUST_LOG` (`info` when unset; `RUST_LOG=debug` adds clusters opened,
//! failed reconnect attempts and each rejected state with why) and written one event per line. Progress is a bar (indicatif) when
//! stderr is a terminal and a plain line per step otherwise, so a log file or CI output reads as
//! lines. While a bar is drawn, log lines and the pods' forwarded lines are printed above it,
//! never through it: everything on stderr goes through [`line()`] or the log writer here.

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use tracing_subscriber::EnvFilter;
use tracing_subscriber::fmt::MakeWriter;

/// The bar being drawn, if any: lines are printed above it.
static BAR: Mutex<Option<ProgressBar>> = Mutex::new(None);

/// Installs the log subscriber: `RUST_LOG` or `info`, to stderr, colour only on a terminal.
/// Calling it again does nothing.
pub fn init_logs() {
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(Stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .try_init();
}

/// Writes `text` and a newline on stderr, above the progress bar if one is drawn.
pub fn line(text: &str) {
    write_above_bar(format!("{text}\n").as_bytes());
}

fn write_above_bar(bytes: &[u8]) {
    let bar = BAR.lock().ok().and_then(|bar| bar.clone());
    let write = || {
        let _ = std::io::stderr().lock().write_all(bytes);
    };
    match bar {
        Some(bar) => bar.suspend(write),
        None => write(),
    }
}

/// The log subscriber's writer: each event is written whole through [`write_above_bar`].
struct Stderr;

impl<'a> MakeWriter<'a> for Stderr {
    type Writer = EventWriter;

    fn make_writer(&'a self) -> Self::Writer {
        EventWriter(Vec::new())
    }
}

/// One log event, buffered until it is complete (dropped), then written at once.
struct EventWriter(Vec<u8>);

impl Write for EventWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Drop for EventWriter {
    fn drop(&mut self) {
        if !self.0.is_empty() {
            write_above_bar(&self.0);
        }
    }
}

/// Progress of one command: a bar on a terminal, `[done/total] message` lines otherwise.
pub struct Progress {
    bar: Option<ProgressBar>,
    done: u64,
    total: Option<u64>,
}

impl Progress {
    /// Progress through `total` steps (`None`: open-ended, shown as elapsed time and a
    /// message).
    pub fn new(total: Option<u64>) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = match total {
                Some(total) => ProgressBar::new(total).with_style(
                    ProgressStyle::with_template(
                        "{elapsed_precise} [{bar:30}] {pos}/{len} {wide_msg}",
                    )
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
                ),
                None => ProgressBar::new_spinner().with_style(
                    ProgressStyle::with_template("{elapsed_precise} {spinner} {wide_msg}")
                        .unwrap_or_else(|_| ProgressStyle::default_spinner()),
                ),
            };
            bar.enable_steady_tick(Duration::from_millis(200));
            if let Ok(mut shown) = BAR.lock() {
                *shown = Some(bar.clone());
            }
            bar
        });
        Self {
            bar,
            done: 0,
            total,
        }
    }

    /// One step done: the bar moves on; without a terminal, `[done/total] message`.
    pub fn step(&mut self, message: &str) {
        self.done += 1;
        match &self.bar {
            Some(bar) => {
                bar.inc(1);
                bar.set_message(message.to_owned());
            }
            None => match self.total {
                Some(total) => line(&format!("[{}/{total}] {message}", self.done)),
                None => line(&format!("[{}] {message}", self.done)),
            },
        }
    }

    /// What is happening now, without a step: the bar's message; without a terminal, a line.
    pub fn status(&self, message: &str) {
        match &self.bar {
            Some(bar) => bar.set_message(message.to_owned()),
            None => line(message),
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
            if let Ok(mut shown) = BAR.lock() {
                *shown = None;
            }
        }
    }
}
