//! [`BenchError`]: why a `seam` command, or a part of one, failed — one error type for the
//! crate, as the library crates have theirs.

use std::fmt::Display;
use std::time::Duration;

/// Why a `seam` command failed. Each variant says what went wrong and, where it helps, what
/// to do; [`BenchError::In`] says where (a pod, a scene, a setting).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BenchError {
    /// A cluster — its transport, its world — failed.
    #[error(transparent)]
    Cluster(#[from] seam_proxy::ClusterError),
    /// A pod could not start.
    #[error(transparent)]
    Pod(#[from] crate::pod::PodError),
    /// A ping run failed.
    #[error(transparent)]
    Ping(#[from] PingError),
    /// A transport could not be opened (outside a cluster: ping, ops, bridges).
    #[error(transparent)]
    Open(#[from] seam_transport::OpenError),
    /// A subscription failed (outside a cluster).
    #[error(transparent)]
    Subscribe(#[from] seam_transport::SubscribeError),
    /// A publish failed (outside a cluster).
    #[error(transparent)]
    Publish(#[from] seam_transport::PublishError),
    /// A receive failed (outside a cluster).
    #[error(transparent)]
    Receive(#[from] seam_transport::ReceiveError),
    /// One world refused an operation.
    #[error(transparent)]
    Sim(#[from] seam_sim::SimError),
    /// Bytes that are not a frame, or a frame that cannot be encoded.
    #[error(transparent)]
    Wire(#[from] seam_sim::wire::WireError),
    /// A scene file is wrong (where, and what).
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// A recording could not be written or read.
    #[error(transparent)]
    Record(#[from] crate::record::RecordError),
    /// A line of JSON could not be written or read.
    #[error("JSON: {0}")]
    Json(#[from] serde_json::Error),
    /// A file, directory, socket or stream could not be read or written.
    #[error("cannot {action} {target}: {source}")]
    Io {
        /// What was being done: `read`, `write`, `create`, `listen on`, `start`…
        action: &'static str,
        /// On what.
        target: String,
        /// Why not.
        #[source]
        source: std::io::Error,
    },
    /// The flags ask for something that cannot be done.
    #[error("{flag}: {problem}")]
    Flag {
        /// The flag (or flags), as written on the command line.
        flag: &'static str,
        /// What is wrong with it.
        problem: String,
    },
    /// A process this one runs or talks to (a pod, a bridge, `redis-server`, `chromedriver`,
    /// `ip`, a peer) failed, or answered what it should not.
    #[error("{process}: {problem}")]
    Process {
        /// Which.
        process: String,
        /// What happened.
        problem: String,
    },
    /// Something waited for did not happen in time.
    #[error("{what} within {waited:?}")]
    Timeout {
        /// What did not happen.
        what: String,
        /// How long it was waited for.
        waited: Duration,
    },
    /// A chart could not be drawn.
    #[error("chart {chart}: {problem}")]
    Chart {
        /// The chart's file.
        chart: String,
        /// What failed.
        problem: String,
    },
    /// A check the command exists to make did not hold (the report above it says which).
    #[error("{0}")]
    Failed(String),
    /// An error, with what to do about it.
    #[error("{source} ({hint})")]
    Hint {
        /// The error.
        #[source]
        source: Box<BenchError>,
        /// What to do.
        hint: &'static str,
    },
    /// Where an error happened.
    #[error("{context}: {source}")]
    In {
        /// Where: a pod, a scene, a trial.
        context: String,
        /// The error.
        #[source]
        source: Box<BenchError>,
    },
}

/// An error that ends a ping run.
#[derive(Debug, thiserror::Error)]
pub enum PingError {
    /// The transport could not be opened or used.
    #[error("{transport}: {reason}")]
    Transport {
        /// Transport URL (password redacted).
        transport: String,
        /// What failed.
        reason: String,
    },
    /// The peer did not answer in time or exited.
    #[error("{transport}: the peer {reason}")]
    Peer {
        /// Transport URL (password redacted).
        transport: String,
        /// What happened.
        reason: String,
    },
}

/// The crate's results.
pub type BenchResult<T> = Result<T, BenchError>;

impl BenchError {
    /// `action` on `target` failed with `source`.
    pub fn io(action: &'static str, target: impl Display, source: std::io::Error) -> Self {
        BenchError::Io {
            action,
            target: target.to_string(),
            source,
        }
    }

    /// `flag` asks for what cannot be done.
    pub fn flag(flag: &'static str, problem: impl Display) -> Self {
        BenchError::Flag {
            flag,
            problem: problem.to_string(),
        }
    }

    /// `process` failed or answered what it should not.
    pub fn process(process: impl Display, problem: impl Display) -> Self {
        BenchError::Process {
            process: process.to_string(),
            problem: problem.to_string(),
        }
    }

    /// This error, with what to do about it.
    pub fn hint(self, hint: &'static str) -> Self {
        BenchError::Hint {
            source: Box::new(self),
            hint,
        }
    }

    /// This error, said to have happened at `context`.
    pub fn within(self, context: impl Display) -> Self {
        BenchError::In {
            context: context.to_string(),
            source: Box::new(self),
        }
    }
}

/// Says where an error happened: `result.context("pod west")?`.
pub trait Context<T> {
    /// The error, if any, within `context`.
    fn context(self, context: impl Display) -> BenchResult<T>;
}

impl<T, E: Into<BenchError>> Context<T> for Result<T, E> {
    fn context(self, context: impl Display) -> BenchResult<T> {
        self.map_err(|e| e.into().within(context))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_say_what_and_where() {
        let e: BenchResult<()> = Err(BenchError::io(
            "write",
            "/tmp/x.csv",
            std::io::Error::from(std::io::ErrorKind::PermissionDenied),
        ));
        let e = e.context("sweep").expect_err("an error");
        assert_eq!(
            e.to_string(),
            "sweep: cannot write /tmp/x.csv: permission denied"
        );
        assert_eq!(
            BenchError::flag("--rate", "must be positive, not 0").to_string(),
            "--rate: must be positive, not 0"
        );
    }
}
