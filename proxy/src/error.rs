//! The one error type of `seam-proxy`.

use seam_sim::SimError;
use seam_sim::wire::ClusterId;
use seam_transport::{ClaimError, OpenError, PublishError, ReceiveError, SubscribeError};

/// Why a cluster could not start or finish a tick.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ClusterError {
    /// A configuration value breaks a rule (see [`ClusterConfig::check`](crate::ClusterConfig::check)).
    #[error("configuration: {0}")]
    Config(#[from] crate::ConfigError),
    /// The transport could not be opened.
    #[error("cannot open the transport: {0}")]
    Open(#[from] OpenError),
    /// A subscription failed.
    #[error("cannot subscribe: {0}")]
    Subscribe(#[from] SubscribeError),
    /// A frame could not be published.
    #[error("cannot publish: {0}")]
    Publish(#[from] PublishError),
    /// Receiving failed.
    #[error("cannot receive: {0}")]
    Receive(#[from] ReceiveError),
    /// The world refused an operation of this cluster's own making.
    #[error("world: {0}")]
    Sim(#[from] SimError),
    /// In lock-step, a neighbour's frames for the tick did not arrive in time.
    #[error(
        "neighbour {neighbour} sent no {what} frame for tick {tick} within {waited_ms} ms: is it running?"
    )]
    NeighbourSilent {
        /// The neighbour.
        neighbour: ClusterId,
        /// `replication` or `physics_events`.
        what: &'static str,
        /// The tick waited for.
        tick: u64,
        /// How long it waited.
        waited_ms: u64,
    },
    /// The entity cannot be handed over (not owned here, or to itself).
    #[error("cannot hand entity {entity} to {to}: {reason}")]
    Transfer {
        /// The entity.
        entity: seam_sim::wire::EntityId,
        /// The intended new owner.
        to: ClusterId,
        /// Why not.
        reason: &'static str,
    },
    /// A frame of this cluster's own could not be encoded (a replication frame naming more
    /// than 255 owners or 65 535 distinct body specs).
    #[error("cannot encode a frame: {0}")]
    Encode(#[from] seam_sim::wire::WireError),
    /// A bridge direction could not open its transports, or stopped on an error.
    #[error("bridge: {url}: {source}")]
    Bridge {
        /// The transport that failed (password redacted).
        url: String,
        /// What failed.
        #[source]
        source: Box<ClusterError>,
    },
    /// A bridge thread could not start, or ended without an error of its own.
    #[error("bridge: {0}")]
    BridgeThread(&'static str),
    /// The two halves of a lock-step tick called out of order (see
    /// [`Cluster::begin_lockstep`](crate::Cluster::begin_lockstep)).
    #[error("lock-step tick out of order: {0}")]
    TickOrder(&'static str),
    /// A free-running schedule that cannot be kept (see `Schedule::new`).
    #[error("schedule: {0}")]
    Schedule(String),
    /// Another pod of this cluster runs already (or took over from this one): one cluster,
    /// one pod (see [`Cluster::new`](crate::Cluster::new)).
    #[error("cluster {cluster} runs already: {source}")]
    AlreadyRunning {
        /// The cluster.
        cluster: ClusterId,
        /// The claim refused or lost, naming the other pod.
        #[source]
        source: ClaimError,
    },
}
