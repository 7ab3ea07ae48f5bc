//! `seam-anchor WORLD.json [TICKS] [RATE]`: steps the world of a `seam_anchor::WorldSpec` file
//! `TICKS` times (default 900) at `RATE` ticks a second (default 60; 0 back to back) and prints
//! the timings as JSON (`seam_anchor::Timings`). Run by `seam capacity`.

use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || args.iter().any(|a| a == "-h" || a == "--help") {
        eprintln!(
            "usage: seam-anchor WORLD.json [TICKS] [RATE]\n\nSteps the world described in \
             WORLD.json (written by `seam capacity`) as one plain Rapier world, TICKS times \
             (900) at RATE ticks a second (60; 0: back to back), and prints each tick's wall \
             and process CPU time as JSON."
        );
        return ExitCode::from(2);
    }
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("seam-anchor: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: &[String]) -> Result<(), String> {
    let path = &args[0];
    let number = |i: usize, default: f64, what: &str| -> Result<f64, String> {
        args.get(i).map_or(Ok(default), |s| {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| format!("{what} must be a number >= 0, not {s:?}"))
        })
    };
    let ticks = number(1, 900.0, "TICKS")? as u64;
    let rate = number(2, 60.0, "RATE")?;
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {path}: {e}"))?;
    let spec: seam_anchor::WorldSpec =
        serde_json::from_str(&text).map_err(|e| format!("{path} is not a world: {e}"))?;
    let mut world = seam_anchor::PlainWorld::new(&spec);
    let timings = seam_anchor::run(&mut world, ticks, rate);
    let json = serde_json::to_string(&timings).map_err(|e| e.to_string())?;
    println!("{json}");
    Ok(())
}
