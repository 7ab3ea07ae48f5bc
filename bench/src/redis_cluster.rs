//! A private Redis Cluster for runs and tests that change it under load: three primaries and
//! three replicas (or fewer of each) on loopback ports of its own, made and taken down by the repository's
//! `tools/redis-cluster` (the one way a cluster is made here), and changed with `redis-cli`:
//! a primary killed as a crash would (its replica takes over), started again (it rejoins as a
//! replica), the slot of a channel moved to another primary.

use std::path::PathBuf;
use std::process::{Command, Stdio};

use crate::error::{BenchError, BenchResult};

/// The script that makes clusters, in this source tree.
pub fn script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tools/redis-cluster")
}

/// A cluster made by `tools/redis-cluster up`; taken down when dropped (unless made to
/// outlive this value, see [`RedisCluster::start_for_process`]).
pub struct RedisCluster {
    url: String,
    base: u16,
    primaries: u16,
    dir: PathBuf,
    take_down: bool,
}

/// One node as `CLUSTER NODES` lists it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClusterNode {
    /// Its node id.
    pub id: String,
    /// Its port on loopback.
    pub port: u16,
    /// Whether it is a primary that has not failed.
    pub primary: bool,
    /// For a replica, the id of its primary.
    pub replica_of: Option<String>,
    /// The slot ranges it serves.
    pub slots: Vec<(u16, u16)>,
}

impl RedisCluster {
    /// Makes a cluster of three primaries on free ports; taken down when dropped.
    pub fn start() -> BenchResult<Self> {
        Self::make(None, 3, None)
    }

    /// Makes a cluster of `primaries` primaries (1 to 3), each with a replica.
    pub fn start_with(primaries: u16) -> BenchResult<Self> {
        Self::make(None, primaries, None)
    }

    /// Makes a cluster of three primaries serving TLS only, with the certificates in `certs`
    /// (`ca.pem`, and `server.pem` and `server.key` naming 127.0.0.1); its URL is
    /// `rediss-cluster://…?tls_ca=…`. Changing it (`kill_primary_of`, `move_slot`) speaks
    /// plain RESP and does not work on it.
    pub fn start_tls(certs: &std::path::Path) -> BenchResult<Self> {
        Self::make(None, 3, Some(certs))
    }

    /// Makes a cluster that lives as long as this process (the script takes it down when the
    /// process exits): for a fixture shared by every test of a process.
    pub fn start_for_process() -> BenchResult<Self> {
        Self::make(Some(std::process::id()), 3, None)
    }

    fn make(
        owner: Option<u32>,
        primaries: u16,
        tls: Option<&std::path::Path>,
    ) -> BenchResult<Self> {
        use std::sync::atomic::{AtomicU32, Ordering};
        static NEXT: AtomicU32 = AtomicU32::new(0);
        let pid = std::process::id();
        let mut failures = Vec::new();
        for _ in 0..4 {
            let n = NEXT.fetch_add(1, Ordering::Relaxed);
            // Ports 21 000 to 30 600 and their cluster-bus ports (+10 000), apart for each
            // process and each cluster it makes.
            let base = 21_000 + ((pid.wrapping_mul(7) + n * 131) % 1_600) as u16 * 6;
            let dir = std::env::temp_dir().join(format!("seam-cluster-{pid}-{base}"));
            let mut command = Command::new(script());
            command.args(["up", "--port", &base.to_string(), "--dir"]);
            command.arg(&dir);
            command.args(["--primaries", &primaries.to_string()]);
            if let Some(owner) = owner {
                command.args(["--owner-pid", &owner.to_string()]);
            }
            if let Some(certs) = tls {
                command.arg("--tls").arg(certs);
            }
            let output = command
                .stdin(Stdio::null())
                .output()
                .map_err(|e| BenchError::io("run", "tools/redis-cluster", e))?;
            let stdout = String::from_utf8_lossy(&output.stdout);
            if output.status.success()
                && let Some(url) = stdout.lines().last()
            {
                return Ok(Self {
                    url: url.trim().to_owned(),
                    base,
                    primaries,
                    dir,
                    take_down: owner.is_none(),
                });
            }
            failures.push(String::from_utf8_lossy(&output.stderr).trim().to_owned());
        }
        Err(BenchError::process(
            "tools/redis-cluster up",
            failures.join(" / "),
        ))
    }

    /// Its transport URL (the three first primaries as seeds).
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The ports of its nodes (primaries first, then their replicas).
    pub fn ports(&self) -> impl Iterator<Item = u16> + '_ {
        (0..2 * self.primaries).map(|i| self.base + i)
    }

    /// The nodes as a live node lists them (`None`: none answers).
    pub fn nodes(&self) -> Option<Vec<ClusterNode>> {
        self.ports()
            .find_map(|port| cli(port, &["cluster", "nodes"]).ok())
            .map(|text| text.lines().filter_map(parse_node).collect())
    }

    /// The slot of `name` (as the cluster hashes it).
    pub fn slot_of(&self, name: &str) -> BenchResult<u16> {
        let port = self.live_port()?;
        cli(port, &["cluster", "keyslot", name])?
            .trim()
            .parse()
            .map_err(|_| BenchError::process("redis-cli cluster keyslot", "no number"))
    }

    /// The primary serving `slot`.
    pub fn primary_of(&self, slot: u16) -> BenchResult<ClusterNode> {
        self.nodes()
            .unwrap_or_default()
            .into_iter()
            .find(|n| n.primary && n.slots.iter().any(|&(a, b)| a <= slot && slot <= b))
            .ok_or_else(|| {
                BenchError::process("redis cluster", format!("no primary serves slot {slot}"))
            })
    }

    fn live_port(&self) -> BenchResult<u16> {
        self.ports()
            .find(|&port| cli(port, &["ping"]).is_ok())
            .ok_or_else(|| BenchError::process("redis cluster", "no node answers"))
    }

    /// Kills the primary serving `slot` with SIGKILL, as a crash would; returns its node index
    /// (0 to 5), to start it again with [`RedisCluster::start_node`].
    pub fn kill_primary_of(&self, slot: u16) -> BenchResult<u16> {
        let node = self.primary_of(slot)?;
        let pidfile = self.dir.join(format!("{}.pid", node.port));
        let pid: i32 = std::fs::read_to_string(&pidfile)
            .map_err(|e| BenchError::io("read", pidfile.display(), e))?
            .trim()
            .parse()
            .map_err(|_| BenchError::process("redis-server", "pid file without a pid"))?;
        let pid = rustix::process::Pid::from_raw(pid)
            .ok_or_else(|| BenchError::process("redis-server", "pid 0"))?;
        rustix::process::kill_process(pid, rustix::process::Signal::KILL)
            .map_err(|e| BenchError::process("kill redis-server", e))?;
        let _ = std::fs::remove_file(&pidfile);
        Ok(node.port - self.base)
    }

    /// Starts node `index` again (it rejoins the cluster from its node file).
    pub fn start_node(&self, index: u16) -> BenchResult<()> {
        let output = Command::new(script())
            .args(["start-node", "--node", &index.to_string()])
            .args(["--port", &self.base.to_string(), "--dir"])
            .arg(&self.dir)
            .stdin(Stdio::null())
            .output()
            .map_err(|e| BenchError::io("run", "tools/redis-cluster start-node", e))?;
        if !output.status.success() {
            return Err(BenchError::process(
                "tools/redis-cluster start-node",
                String::from_utf8_lossy(&output.stderr).trim(),
            ));
        }
        Ok(())
    }

    /// Whether the process of every node but `down` (a node index) is alive (cheap: read
    /// from their pid files, no command sent).
    pub fn processes_alive(&self, down: Option<u16>) -> bool {
        self.ports()
            .enumerate()
            .filter(|&(i, _)| Some(i as u16) != down)
            .all(|(_, port)| {
                std::fs::read_to_string(self.dir.join(format!("{port}.pid")))
                    .ok()
                    .and_then(|pid| pid.trim().parse::<i32>().ok())
                    .and_then(rustix::process::Pid::from_raw)
                    .is_some_and(|pid| rustix::process::test_kill_process(pid).is_ok())
            })
    }

    /// Moves `slot` from its primary to another (the steps `redis-cli --cluster reshard`
    /// takes for each slot: importing, migrating, then the new owner announced to both; no
    /// keys to move, pub/sub keeps none). Returns the ports it moved from and to. Right after
    /// a failover or a restart the nodes' views of who owns a slot can disagree for a moment,
    /// and the primary one node names answers that it is not the owner: the move is then
    /// undone at the importing node and tried again, at most 20 times, 250 ms apart.
    pub fn move_slot(&self, slot: u16) -> BenchResult<(u16, u16)> {
        let mut tries = 0;
        loop {
            match self.try_move_slot(slot) {
                Err(e) if tries < 20 && e.to_string().contains("not the owner") => {
                    tries += 1;
                    std::thread::sleep(std::time::Duration::from_millis(250));
                }
                moved => return moved,
            }
        }
    }

    fn try_move_slot(&self, slot: u16) -> BenchResult<(u16, u16)> {
        let from = self.primary_of(slot)?;
        let to = self
            .nodes()
            .unwrap_or_default()
            .into_iter()
            .find(|n| n.primary && n.id != from.id)
            .ok_or_else(|| BenchError::process("redis cluster", "no other primary"))?;
        let slot = slot.to_string();
        cli(
            to.port,
            &["cluster", "setslot", &slot, "importing", &from.id],
        )?;
        if let Err(e) = cli(
            from.port,
            &["cluster", "setslot", &slot, "migrating", &to.id],
        ) {
            let _ = cli(to.port, &["cluster", "setslot", &slot, "stable"]);
            return Err(e);
        }
        for port in [to.port, from.port] {
            cli(port, &["cluster", "setslot", &slot, "node", &to.id])?;
        }
        Ok((from.port, to.port))
    }
}

impl Drop for RedisCluster {
    fn drop(&mut self) {
        if !self.take_down {
            return;
        }
        let _ = Command::new(script())
            .args(["down", "--port", &self.base.to_string(), "--dir"])
            .arg(&self.dir)
            .stdin(Stdio::null())
            .output();
    }
}

/// `redis-cli -p PORT ARGS…`'s output; an error if it fails or the server answers one.
pub fn cli(port: u16, args: &[&str]) -> BenchResult<String> {
    let output = Command::new("redis-cli")
        .args(["-p", &port.to_string()])
        .args(args)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| BenchError::io("run", "redis-cli", e))?;
    let text = String::from_utf8_lossy(&output.stdout).into_owned();
    if !output.status.success() || text.starts_with("ERR") || text.contains("Could not connect") {
        return Err(BenchError::process(
            format!("redis-cli -p {port} {}", args.join(" ")),
            text.trim(),
        ));
    }
    Ok(text)
}

/// One line of `CLUSTER NODES`: `id host:port@bus flags primary-id ping pong epoch link slots…`.
fn parse_node(line: &str) -> Option<ClusterNode> {
    let words: Vec<&str> = line.split(' ').collect();
    let port = words
        .get(1)?
        .split('@')
        .next()?
        .rsplit_once(':')?
        .1
        .parse()
        .ok()?;
    let flags = words.get(2)?;
    let slots = words
        .iter()
        .skip(8)
        .filter(|w| !w.starts_with('['))
        .filter_map(|range| {
            let (a, b) = range.split_once('-').unwrap_or((range, range));
            Some((a.parse().ok()?, b.parse().ok()?))
        })
        .collect();
    Some(ClusterNode {
        id: words[0].to_owned(),
        port,
        primary: flags.contains("master") && !flags.contains("fail"),
        replica_of: words.get(3).filter(|w| **w != "-").map(|w| (*w).to_owned()),
        slots,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cluster_nodes_lines_read() {
        let primary = parse_node(
            "d239 127.0.0.1:7000@17000 myself,master - 0 0 1 connected 0-5460 5470 [5461->-abc]",
        )
        .expect("reads");
        assert_eq!(primary.port, 7000);
        assert!(primary.primary);
        assert_eq!(primary.slots, [(0, 5460), (5470, 5470)]);
        let replica =
            parse_node("65ac 127.0.0.1:7005@17005 slave d239 0 1 6 connected").expect("reads");
        assert!(!replica.primary);
        assert_eq!(replica.replica_of.as_deref(), Some("d239"));
        let failed = parse_node("9f03 127.0.0.1:7002@17002 master,fail - 0 1 3 disconnected")
            .expect("reads");
        assert!(!failed.primary);
    }
}
