//! Simulated hosts as Linux network namespaces, made (as root) by the run and removed after.
//!
//! Each host gets a namespace `seam<tag><k>` and a veth pair: `sm<tag><k>r` in this namespace
//! and `sm<tag><k>n` inside, a /30 of 10.213.0.0/16 between them. The host's bridge and pods run
//! inside (`ip netns exec`); the bridge reaches the Redis server only through a [`Relay`]
//! listening on 10.213.k.1, which may delay the traffic of that host. No traffic goes anywhere
//! but loopback and those veth addresses. Shared memory is not a network resource, so each
//! host also keeps its own iceoryx2 prefix.

use std::ffi::OsStr;
use std::net::{IpAddr, Ipv4Addr, SocketAddr, ToSocketAddrs};
use std::process::{Command, Stdio};

use crate::error::{BenchError, BenchResult};
use crate::relay::{Delay, Relay};

/// The namespaces of a run, removed when dropped.
pub(super) struct Namespaces {
    hosts: Vec<Namespace>,
}

struct Namespace {
    host: String,
    name: String,
    veth: String,
    relay: Relay,
}

/// Runs `ip` with `args`; its error output on failure.
fn ip<I, S>(args: I) -> BenchResult<()>
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let args: Vec<S> = args.into_iter().collect();
    let shown: Vec<String> = args
        .iter()
        .map(|a| a.as_ref().to_string_lossy().into_owned())
        .collect();
    let output = Command::new("ip")
        .args(&args)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| BenchError::io("run", "`ip`", e))?;
    if output.status.success() {
        Ok(())
    } else {
        Err(BenchError::process(
            format!("`ip {}`", shown.join(" ")),
            String::from_utf8_lossy(&output.stderr).trim(),
        ))
    }
}

/// A /24 of 10.213.0.0/16 for one run: host `k` gets the /30 at `4k`. Runs in one process
/// take different ones; runs of different processes most likely do.
struct Subnet(u8);

impl Subnet {
    fn next() -> Self {
        static RUNS: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let run = RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Self((std::process::id().wrapping_mul(31).wrapping_add(run * 97) % 256) as u8)
    }

    /// Address `last` (1 or 2) of host `k`'s /30.
    fn host(&self, k: usize, last: u8) -> Ipv4Addr {
        Ipv4Addr::new(10, 213, self.0, (4 * k) as u8 + last)
    }
}

/// The `host:port` a Redis URL names (TCP only).
pub(super) fn redis_addr(url: &str) -> BenchResult<SocketAddr> {
    let rest = url
        .strip_prefix("redis://")
        .ok_or_else(|| BenchError::flag("--redis", "simulated hosts need a redis:// URL (TCP)"))?;
    let authority = rest.split(['/', '?']).next().unwrap_or(rest);
    let hostport = authority.rsplit('@').next().unwrap_or(authority);
    let hostport = if hostport.contains(':') {
        hostport.to_owned()
    } else {
        format!("{hostport}:6379")
    };
    hostport
        .to_socket_addrs()
        .map_err(|e| BenchError::io("resolve", &hostport, e))?
        .find(|a| a.ip().is_loopback())
        .ok_or_else(|| {
            BenchError::flag(
                "--redis",
                format!(
                    "{hostport}: simulated hosts reach only a Redis server on this machine's \
                     loopback"
                ),
            )
        })
}

/// `url` with its `host:port` replaced by `addr` (credentials, database and settings kept).
pub(super) fn redirect(url: &str, addr: SocketAddr) -> String {
    let rest = url.strip_prefix("redis://").unwrap_or(url);
    let end = rest.find(['/', '?']).unwrap_or(rest.len());
    let (authority, tail) = rest.split_at(end);
    let credentials = authority
        .rsplit_once('@')
        .map_or(String::new(), |(c, _)| format!("{c}@"));
    format!("redis://{credentials}{addr}{tail}")
}

impl Namespaces {
    /// One namespace per host in `hosts`, each with a relay to the Redis server of `redis` that
    /// delays host `delayed` (if any) by `delay`. An error (not root, no `ip`, no namespaces)
    /// removes whatever was made.
    pub(super) fn create(
        tag: &str,
        hosts: &[String],
        redis: &str,
        delayed: Option<(&str, Delay)>,
    ) -> BenchResult<Self> {
        if !rustix::process::geteuid().is_root() {
            return Err(BenchError::process("network namespaces", "need root"));
        }
        let upstream = redis_addr(redis)?;
        if hosts.len() > 63 {
            return Err(BenchError::flag("--hosts", "at most 63 simulated hosts"));
        }
        let subnet = Subnet::next();
        let mut made = Self { hosts: Vec::new() };
        for (k, host) in hosts.iter().enumerate() {
            let name = format!("seam{tag}{k}");
            let veth = format!("sm{tag}{k}r");
            let inner = format!("sm{tag}{k}n");
            let (outer_ip, inner_ip) = (subnet.host(k, 1), subnet.host(k, 2));
            ip(["netns", "add", &name])?;
            // Registered now, so a failure below removes the namespace too.
            let steps = || -> BenchResult<Relay> {
                ip(["link", "add", &veth, "type", "veth", "peer", "name", &inner])?;
                ip(["link", "set", &inner, "netns", &name])?;
                ip(["addr", "add", &format!("{outer_ip}/30"), "dev", &veth])?;
                ip(["link", "set", &veth, "up"])?;
                let inside = |args: &[&str]| {
                    let mut all = vec!["netns", "exec", &name, "ip"];
                    all.extend_from_slice(args);
                    ip(all)
                };
                inside(&["addr", "add", &format!("{inner_ip}/30"), "dev", &inner])?;
                inside(&["link", "set", &inner, "up"])?;
                inside(&["link", "set", "lo", "up"])?;
                let delay = match delayed {
                    Some((h, d)) if h == host => d,
                    _ => Delay::NONE,
                };
                Relay::start(SocketAddr::new(IpAddr::V4(outer_ip), 0), upstream, delay)
            };
            match steps() {
                Ok(relay) => made.hosts.push(Namespace {
                    host: host.clone(),
                    name,
                    veth,
                    relay,
                }),
                Err(e) => {
                    let _ = ip(["link", "del", &veth]);
                    let _ = ip(["netns", "del", &name]);
                    return Err(e);
                }
            }
        }
        Ok(made)
    }

    /// The namespace of `host`.
    fn of(&self, host: &str) -> Option<&Namespace> {
        self.hosts.iter().find(|n| n.host == host)
    }

    /// The namespace name of `host`.
    pub(super) fn name(&self, host: &str) -> Option<&str> {
        self.of(host).map(|n| n.name.as_str())
    }

    /// The Redis URL as seen from inside `host`: its relay's veth address.
    pub(super) fn redis_url(&self, host: &str, redis: &str) -> String {
        match self.of(host) {
            Some(ns) => redirect(redis, ns.relay.addr()),
            None => redis.to_owned(),
        }
    }

    /// What the report says the hosts were.
    pub(super) fn describe(&self) -> String {
        let hosts: Vec<String> = self
            .hosts
            .iter()
            .map(|n| format!("{} = netns {} via {}", n.host, n.name, n.relay.addr()))
            .collect();
        format!(
            "network namespaces ({}), each reaching Redis only through a relay on its veth address; shared memory separated by iceoryx2 prefix",
            hosts.join(", ")
        )
    }
}

impl Drop for Namespaces {
    fn drop(&mut self) {
        for ns in &self.hosts {
            let _ = ip(["link", "del", &ns.veth]);
            let _ = ip(["netns", "del", &ns.name]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn redis_urls_are_redirected_with_their_settings() {
        let to: SocketAddr = "10.213.0.1:40000".parse().expect("addr");
        assert_eq!(
            redirect("redis://127.0.0.1:6379", to),
            "redis://10.213.0.1:40000"
        );
        assert_eq!(
            redirect("redis://user:pw@localhost:6380/2?timeout_ms=50", to),
            "redis://user:pw@10.213.0.1:40000/2?timeout_ms=50"
        );
        assert_eq!(
            redis_addr("redis://127.0.0.1").expect("loopback"),
            "127.0.0.1:6379".parse::<SocketAddr>().expect("addr")
        );
        assert!(redis_addr("redis+unix:///tmp/redis.sock").is_err());
    }
}
