//! The rows `seam capacity` measures: what each is, read from `--rows`, and the default set.

use super::Build;

/// One configuration measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Row {
    /// Plain Rapier, built as said.
    Rapier(Build),
    /// The scene cut as for `Seam { pods: worlds }`, each part's own bodies (and all the
    /// scenery) a plain one-thread Rapier world of its own, all stepped at once in processes
    /// side by side, nothing crossing between them: what a split over that many processes
    /// could hold on this host if the seam cost nothing. Bodies of different parts never meet
    /// here, so it is an upper bound for any split, not a simulation of the scene.
    Apart {
        /// How many worlds.
        worlds: usize,
    },
    /// seam's pods.
    Seam {
        /// How many.
        pods: usize,
    },
}

impl Row {
    /// Reads `rapier`, `rapier-ed`, `parallel`, `parallel-ed`, `apart:N` or `seam:N`.
    pub fn parse(text: &str) -> Result<Row, String> {
        let rapier = |parallel, determinism| {
            Ok(Row::Rapier(Build {
                parallel,
                determinism,
            }))
        };
        match text {
            "rapier" => rapier(false, false),
            "rapier-ed" => rapier(false, true),
            "parallel" => rapier(true, false),
            "parallel-ed" => rapier(true, true),
            _ => {
                let count = |prefix: &str| {
                    text.strip_prefix(prefix)
                        .and_then(|n| n.parse::<usize>().ok())
                        .filter(|&n| n > 0)
                };
                if let Some(pods) = count("seam:") {
                    Ok(Row::Seam { pods })
                } else if let Some(worlds) = count("apart:") {
                    Ok(Row::Apart { worlds })
                } else {
                    Err(format!(
                        "{text:?} is not a row: rapier, rapier-ed, parallel, parallel-ed, \
                         apart:N (N plain worlds side by side, at least 1) or seam:N (N pods, \
                         at least 1)"
                    ))
                }
            }
        }
    }

    /// What the row is, in words.
    pub fn label(&self) -> String {
        match *self {
            Row::Rapier(build) => {
                let threads = if build.parallel {
                    format!("parallel, {} threads", cores())
                } else {
                    "1 thread".to_owned()
                };
                let determinism = if build.determinism {
                    ", enhanced-determinism"
                } else {
                    ""
                };
                format!("Rapier {threads}{determinism}")
            }
            Row::Apart { worlds } => format!("Rapier, {worlds} worlds apart"),
            Row::Seam { pods } => format!("seam, {pods} pods"),
        }
    }
}

/// The cores this host has.
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, usize::from)
}

/// The rows measured unless told otherwise: plain Rapier on one thread and in parallel (with
/// and without enhanced determinism), as many plain worlds apart as cores (the most a split
/// could hold), seam with as many pods as cores, and with four.
pub fn default_rows() -> Vec<Row> {
    let mut rows = vec![
        Row::parse("rapier"),
        Row::parse("parallel"),
        Row::parse("parallel-ed"),
    ]
    .into_iter()
    .flatten()
    .collect::<Vec<_>>();
    rows.push(Row::Apart { worlds: cores() });
    rows.push(Row::Seam { pods: cores() });
    if cores() != 4 {
        rows.push(Row::Seam { pods: 4 });
    }
    rows
}
