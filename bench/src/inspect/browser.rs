//! Headless Chromium driven through ChromeDriver's WebDriver protocol (plain HTTP and JSON on
//! loopback): what the browser test and `seam inspect --measure` use to load the page, read its
//! state and take screenshots.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::error::{BenchError, BenchResult};

/// Where ChromeDriver is looked for (`SEAM_CHROMEDRIVER` first).
const DRIVERS: [&str; 2] = ["/usr/bin/chromedriver", "/usr/lib/chromium/chromedriver"];
/// Where Chromium is looked for (`SEAM_CHROMIUM` first).
const BROWSERS: [&str; 2] = ["/usr/bin/chromium", "/usr/bin/chromium-browser"];

fn find(var: &str, paths: &[&str]) -> Option<PathBuf> {
    std::env::var_os(var)
        .map(PathBuf::from)
        .into_iter()
        .chain(paths.iter().map(PathBuf::from))
        .find(|p| p.is_file())
}

/// The browser and driver binaries, or why they are missing.
pub fn binaries() -> BenchResult<(PathBuf, PathBuf)> {
    let driver = find("SEAM_CHROMEDRIVER", &DRIVERS).ok_or_else(|| {
        BenchError::process(
            "chromedriver",
            "not found (install Debian's chromium-driver, or set SEAM_CHROMEDRIVER)",
        )
    })?;
    let browser = find("SEAM_CHROMIUM", &BROWSERS).ok_or_else(|| {
        BenchError::process(
            "chromium",
            "not found (install Debian's chromium, or set SEAM_CHROMIUM)",
        )
    })?;
    Ok((browser, driver))
}

/// One headless browser session; the browser and its driver end when dropped.
pub struct Browser {
    driver: Child,
    port: u16,
    session: String,
    profile: PathBuf,
}

impl Browser {
    /// Starts ChromeDriver and a headless Chromium session (a fresh profile, no network
    /// services, a 1 400 × 1 000 window).
    pub fn start() -> BenchResult<Self> {
        let (browser, driver) = binaries()?;
        let port = free_port()?;
        let profile =
            std::env::temp_dir().join(format!("seam-chromium-{}-{port}", std::process::id()));
        let child = Command::new(&driver)
            .arg(format!("--port={port}"))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| BenchError::io("start", driver.display(), e))?;
        let mut this = Self {
            driver: child,
            port,
            session: String::new(),
            profile,
        };
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            match this.request("GET", "/status", None) {
                Ok(v) if v["value"]["ready"] == json!(true) => break,
                _ if Instant::now() > deadline => {
                    return Err(BenchError::Timeout {
                        what: format!("{} did not answer", driver.display()),
                        waited: Duration::from_secs(20),
                    });
                }
                _ => std::thread::sleep(Duration::from_millis(100)),
            }
        }
        let args = [
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-dev-shm-usage",
            "--window-size=1400,1000",
        ];
        let mut args: Vec<String> = args.iter().map(|a| (*a).to_owned()).collect();
        args.push(format!("--user-data-dir={}", this.profile.display()));
        let caps = json!({
            "capabilities": { "alwaysMatch": {
                "browserName": "chrome",
                "goog:chromeOptions": { "binary": browser, "args": args },
            }}
        });
        let answer = this.request("POST", "/session", Some(&caps))?;
        this.session = answer["value"]["sessionId"]
            .as_str()
            .ok_or_else(|| {
                BenchError::process("chromedriver", format!("started no session: {answer}"))
            })?
            .to_owned();
        Ok(this)
    }

    /// Opens `url` and waits for the page to load.
    pub fn goto(&self, url: &str) -> BenchResult<()> {
        self.command("POST", "url", Some(&json!({ "url": url })))
            .map(drop)
    }

    /// The value of `script` (a function body: `return …;`) run in the page.
    pub fn eval(&self, script: &str) -> BenchResult<Value> {
        self.command(
            "POST",
            "execute/sync",
            Some(&json!({ "script": script, "args": [] })),
        )
        .map(|v| v["value"].clone())
    }

    /// Polls `expression` until it is true or `timeout` passes.
    pub fn wait_for(&self, expression: &str, timeout: Duration) -> BenchResult<()> {
        let deadline = Instant::now() + timeout;
        loop {
            if self.eval(&format!("return !!({expression});"))? == json!(true) {
                return Ok(());
            }
            if Instant::now() > deadline {
                return Err(BenchError::Timeout {
                    what: format!("{expression} did not become true"),
                    waited: timeout,
                });
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Saves a screenshot of the window as PNG.
    pub fn screenshot(&self, path: &Path) -> BenchResult<()> {
        let v = self.command("GET", "screenshot", None)?;
        let text = v["value"]
            .as_str()
            .ok_or_else(|| BenchError::process("chromedriver", "no screenshot in the answer"))?;
        let png = super::base64_decode(text)
            .ok_or_else(|| BenchError::process("chromedriver", "the screenshot is not base64"))?;
        std::fs::write(path, png).map_err(|e| BenchError::io("write", path.display(), e))
    }

    fn command(&self, method: &str, what: &str, body: Option<&Value>) -> BenchResult<Value> {
        let path = format!("/session/{}/{what}", self.session);
        let v = self.request(method, &path, body)?;
        if let Some(error) = v["value"]["error"].as_str() {
            return Err(BenchError::process(
                "browser",
                format!("{error}: {}", v["value"]["message"].as_str().unwrap_or("")),
            ));
        }
        Ok(v)
    }

    fn request(&self, method: &str, path: &str, body: Option<&Value>) -> BenchResult<Value> {
        let body = body.map(Value::to_string).unwrap_or_default();
        let mut stream = TcpStream::connect(("127.0.0.1", self.port)).map_err(|e| {
            BenchError::io(
                "connect to",
                format!("chromedriver on port {}", self.port),
                e,
            )
        })?;
        stream
            .set_read_timeout(Some(Duration::from_secs(120)))
            .map_err(|e| BenchError::io("set a timeout on", "chromedriver's socket", e))?;
        write!(
            stream,
            "{method} {path} HTTP/1.1\r\nhost: 127.0.0.1:{}\r\ncontent-type: application/json\r\n\
             content-length: {}\r\nconnection: close\r\n\r\n{body}",
            self.port,
            body.len()
        )
        .map_err(|e| BenchError::io("write to", "chromedriver", e))?;
        // Read until the body is whole: the driver may keep the connection open.
        let mut answer = Vec::new();
        let mut buf = [0u8; 64 * 1024];
        loop {
            if let Some(split) = answer.windows(4).position(|w| w == b"\r\n\r\n") {
                let head = String::from_utf8_lossy(&answer[..split]).to_ascii_lowercase();
                let body = &answer[split + 4..];
                let length = head.lines().find_map(|l| {
                    l.strip_prefix("content-length:")
                        .and_then(|v| v.trim().parse::<usize>().ok())
                });
                let whole = match length {
                    Some(n) if body.len() >= n => Some(body[..n].to_vec()),
                    Some(_) => None,
                    None if head.contains("transfer-encoding: chunked") => unchunk(body),
                    None => None,
                };
                if let Some(body) = whole {
                    return Ok(serde_json::from_slice(&body)?);
                }
            }
            let n = stream
                .read(&mut buf)
                .map_err(|e| BenchError::io("read from", "chromedriver", e))?;
            if n == 0 {
                return Err(BenchError::process(
                    "chromedriver",
                    "closed the connection mid-answer",
                ));
            }
            answer.extend_from_slice(&buf[..n]);
        }
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if !self.session.is_empty() {
            let path = format!("/session/{}", self.session);
            let _ = self.request("DELETE", &path, None);
        }
        let _ = self.driver.kill();
        let _ = self.driver.wait();
        let _ = std::fs::remove_dir_all(&self.profile);
    }
}

fn unchunk(mut body: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    loop {
        let line = body.windows(2).position(|w| w == b"\r\n")?;
        let size =
            usize::from_str_radix(std::str::from_utf8(&body[..line]).ok()?.trim(), 16).ok()?;
        body = &body[line + 2..];
        if size == 0 {
            return Some(out);
        }
        out.extend_from_slice(body.get(..size)?);
        body = body.get(size + 2..)?;
    }
}

fn free_port() -> BenchResult<u16> {
    let io = |e| BenchError::io("find", "a free port on loopback", e);
    let listener = std::net::TcpListener::bind("127.0.0.1:0").map_err(io)?;
    listener.local_addr().map(|a| a.port()).map_err(io)
}

/// What the page measured of itself.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PageFigures {
    /// From navigation to the recording drawn, ms (the page's own clock).
    pub load_ms: f64,
    /// Random ticks drawn per second, one after another.
    pub scrub_fps: f64,
    /// Ticks in the recording.
    pub ticks: u64,
    /// Hand-offs the page found.
    pub handoffs: u64,
    /// Errors the page caught.
    pub errors: Vec<String>,
}

/// Loads `url` in a fresh headless browser and reads the page's own load time and scrub rate
/// (`frames` random ticks drawn back to back).
pub fn measure(url: &str, frames: u32) -> BenchResult<PageFigures> {
    let browser = Browser::start()?;
    browser.goto(url)?;
    browser.wait_for(
        "window.seam && (window.seam.ready || window.seam.errors.length > 0)",
        Duration::from_secs(120),
    )?;
    let v = browser.eval(&format!(
        "return {{ load: seam.loadMs, fps: seam.ready ? seam.measureScrub({frames}) : 0, \
         ticks: seam.ticks.length, handoffs: seam.handoffs.length, errors: seam.errors }};"
    ))?;
    Ok(PageFigures {
        load_ms: v["load"].as_f64().unwrap_or(f64::NAN),
        scrub_fps: v["fps"].as_f64().unwrap_or(0.0),
        ticks: v["ticks"].as_u64().unwrap_or(0),
        handoffs: v["handoffs"].as_u64().unwrap_or(0),
        errors: v["errors"]
            .as_array()
            .map(|a| a.iter().map(|e| e.to_string()).collect())
            .unwrap_or_default(),
    })
}
