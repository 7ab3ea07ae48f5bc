//! seam-proxy — placeholder overview, rewritten below.

mod channels;
mod cluster;
mod config;
mod error;
mod inbox;
mod lockstep;
mod stats;

pub use channels::{physics_events, replication};
pub use cluster::Cluster;
pub use config::{ClusterConfig, CustomProxy, ProxyMode, Region};
pub use error::ClusterError;
pub use lockstep::lockstep_round;
pub use stats::ClusterStats;
