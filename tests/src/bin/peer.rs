//! `seam-test-peer` — the other process in cross-process tests.
//!
//! ```text
//! seam-test-peer echo URL IN OUT COUNT     subscribe IN, publish each message back on OUT
//! seam-test-peer publish URL CHANNEL COUNT publish COUNT numbered messages on CHANNEL
//! ```
//!
//! Each prints `ready` once subscribed or opened and `done` when finished, then waits for a line
//! (or end of input) on stdin before exiting: on shared memory a publisher's unread messages go
//! with it, so the parent says when it has read them.

use std::io::{BufRead, Write};
use std::process::ExitCode;
use std::time::Duration;

fn say(line: &str) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{line}");
    let _ = out.flush();
}

fn wait_for_parent() {
    let mut line = String::new();
    let _ = std::io::stdin().lock().read_line(&mut line);
}

fn run(args: &[String]) -> Result<(), String> {
    let number = |s: &str| s.parse::<u64>().map_err(|e| format!("{s:?}: {e}"));
    match args {
        [mode, url, input, output, count] if mode == "echo" => {
            let count = number(count)?;
            let mut transport = seam_transport::open(url).map_err(|e| e.to_string())?;
            transport.subscribe(input).map_err(|e| e.to_string())?;
            say("ready");
            let mut echoed = 0;
            while echoed < count {
                let payload = match transport
                    .receive_timeout(Duration::from_secs(20))
                    .map_err(|e| e.to_string())?
                {
                    Some(message) => message.payload.to_vec(),
                    None => return Err(format!("no message after {echoed} echoes")),
                };
                transport
                    .publish(output, &payload)
                    .map_err(|e| e.to_string())?;
                echoed += 1;
            }
            say("done");
            wait_for_parent();
            Ok(())
        }
        [mode, url, channel, count] if mode == "publish" => {
            let count = number(count)?;
            let mut transport = seam_transport::open(url).map_err(|e| e.to_string())?;
            say("ready");
            for i in 0..count {
                transport
                    .publish(channel, &i.to_le_bytes())
                    .map_err(|e| e.to_string())?;
            }
            say("done");
            wait_for_parent();
            Ok(())
        }
        _ => Err("usage: seam-test-peer echo URL IN OUT COUNT | publish URL CHANNEL COUNT".into()),
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("seam-test-peer: {e}");
            ExitCode::FAILURE
        }
    }
}
