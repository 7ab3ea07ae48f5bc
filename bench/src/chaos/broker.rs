//! What carries a chaos run's frames, and its own faults: shared memory (none), a private
//! Redis server (killed and started again), or a private Redis Cluster (a primary killed as a
//! crash would, its replica taking over, the node started again to rejoin as a replica; and the
//! slot of a live channel moved to another primary).

use std::time::Duration;

use super::schedule::Fault;
use crate::error::BenchResult;
use crate::redis_cluster::RedisCluster;
use crate::redis_server::RedisServer;

/// The transport a chaos run's pods use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Broker {
    /// Shared memory under a private prefix.
    Shm,
    /// A private `redis-server`.
    Redis,
    /// A private Redis Cluster (`tools/redis-cluster`: three primaries, three replicas).
    RedisCluster,
}

/// How long a killed Redis server is down.
pub(super) const REDIS_DOWN_FOR: Duration = Duration::from_secs(1);
/// How long a killed primary is down: long enough for its replica to be promoted (the
/// cluster's nodes time out after 1 s).
pub(super) const PRIMARY_DOWN_FOR: Duration = Duration::from_secs(3);

/// The running server of a run, if it has one.
pub(super) enum Server {
    None,
    Single(RedisServer),
    Cluster {
        cluster: RedisCluster,
        /// The node killed and not started again yet.
        down: Option<u16>,
    },
}

impl Server {
    /// Starts what `broker` needs.
    pub(super) fn start(broker: Broker) -> BenchResult<Self> {
        Ok(match broker {
            Broker::Shm => Server::None,
            Broker::Redis => Server::Single(RedisServer::start()?),
            Broker::RedisCluster => Server::Cluster {
                cluster: RedisCluster::start()?,
                down: None,
            },
        })
    }

    /// The pods' transport URL (`None`: shared memory).
    pub(super) fn url(&self) -> Option<String> {
        match self {
            Server::None => None,
            Server::Single(server) => Some(server.url()),
            Server::Cluster { cluster, .. } => Some(cluster.url().to_owned()),
        }
    }

    /// The faults a run takes in turn.
    pub(super) fn faults(&self) -> Vec<Fault> {
        match self {
            Server::None => vec![Fault::Kill, Fault::Stop],
            Server::Single(_) => vec![Fault::Kill, Fault::RestartRedis, Fault::Stop],
            Server::Cluster { .. } => {
                vec![
                    Fault::Kill,
                    Fault::MoveSlot,
                    Fault::Stop,
                    Fault::KillPrimary,
                ]
            }
        }
    }

    /// Whether every part runs that should (a part a fault took down aside).
    pub(super) fn is_running(&self) -> bool {
        match self {
            Server::None => true,
            Server::Single(server) => server.is_running(),
            Server::Cluster { cluster, down } => cluster.processes_alive(*down),
        }
    }

    /// Takes the server, or the primary serving `channel`, down; says what it did.
    pub(super) fn take_down(&mut self, channel: &str) -> BenchResult<String> {
        match self {
            Server::None => Ok("nothing to take down".into()),
            Server::Single(server) => {
                server.kill();
                Ok("Redis server killed".into())
            }
            Server::Cluster { cluster, down } => {
                let slot = cluster.slot_of(channel)?;
                let node = cluster.kill_primary_of(slot)?;
                *down = Some(node);
                Ok(format!(
                    "Redis Cluster primary (node {node}) of {channel}'s slot {slot} killed"
                ))
            }
        }
    }

    /// Brings back what [`Server::take_down`] took down; says what it did.
    pub(super) fn bring_back(&mut self) -> BenchResult<String> {
        match self {
            Server::None => Ok(String::new()),
            Server::Single(server) => {
                server.restart()?;
                Ok("Redis server restarted".into())
            }
            Server::Cluster { cluster, down } => match down.take() {
                Some(node) => {
                    cluster.start_node(node)?;
                    Ok(format!("Redis Cluster node {node} started again"))
                }
                None => Ok(String::new()),
            },
        }
    }

    /// Moves the slot of `channel` to another primary (a Redis Cluster only); says what it did.
    pub(super) fn move_slot(&mut self, channel: &str) -> BenchResult<String> {
        match self {
            Server::Cluster { cluster, .. } => {
                let slot = cluster.slot_of(channel)?;
                let (from, to) = cluster.move_slot(slot)?;
                Ok(format!(
                    "slot {slot} of {channel} moved from port {from} to {to}"
                ))
            }
            _ => Ok("no slots to move".into()),
        }
    }
}
