//! `seam run --hosts N`: pods on several simulated hosts, one `seam bridge` per host.
//!
//! A simulated host here is its own iceoryx2 prefix on this machine: its pods share memory with
//! each other and with nobody else, and its bridge carries what crosses hosts over the Redis
//! server. The report says so (`HostsSummary::simulated_as`).

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::Duration;

use serde::{Deserialize, Serialize};

use std::collections::HashMap;

use crate::bridge::{BridgeLine, BridgeReport, host_url};
use crate::error::{BenchError, BenchResult};
use crate::node::NodeReport;
use crate::pod::{OpStages, OpStagesSummary};
use crate::relay::{Delay, Relay};
use crate::scene::Scene;

use super::RunPlan;
use super::netns::{Namespaces, redirect};

/// How `seam run` lays pods out on hosts.
#[derive(Debug, Clone)]
pub struct HostsPlan {
    /// Simulated hosts for a scene whose clusters name none (`None`: the scene's, or one).
    pub count: Option<u32>,
    /// The Redis server between hosts.
    pub redis: String,
    /// Delay the traffic between one host and Redis by this much each way (simulated latency).
    pub delay: Delay,
    /// The host delayed (default: the last).
    pub delayed_host: Option<String>,
    /// Make hosts network namespaces when root (otherwise, or if that fails, prefixes only).
    pub namespaces: bool,
}

impl Default for HostsPlan {
    fn default() -> Self {
        Self {
            count: None,
            redis: "redis://127.0.0.1:6379".to_owned(),
            delay: Delay::NONE,
            delayed_host: None,
            namespaces: true,
        }
    }
}

/// How the hosts of a run were simulated, and what their bridges did.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct HostsSummary {
    /// How the hosts were made.
    pub simulated_as: String,
    /// Host of each pod, in the scene's order of clusters.
    pub layout: Vec<String>,
    /// One report per host's bridge.
    pub bridges: Vec<BridgeReport>,
    /// Stages of the routed ops applied by a pod of the host that published them.
    pub ops_same_host: Option<OpStagesSummary>,
    /// Stages of the routed ops that crossed hosts (through two bridges and Redis).
    pub ops_cross_host: Option<OpStagesSummary>,
}

impl HostsSummary {
    /// Splits the pods' routed-op stages into those that stayed on a host and those that
    /// crossed, by the host of the pod that sent each op's frame.
    pub(super) fn split_ops(&mut self, scene: &Scene, reports: &[NodeReport]) {
        let host_of: HashMap<&str, &str> = scene
            .clusters
            .iter()
            .zip(&self.layout)
            .map(|(c, h)| (c.name.as_str(), h.as_str()))
            .collect();
        let (mut same, mut cross) = (OpStages::default(), OpStages::default());
        for report in reports {
            let here = host_of.get(report.cluster.as_str());
            for (sender, stages) in &report.ops_by_sender {
                if host_of.get(sender.as_str()) == here {
                    same.merge(stages);
                } else {
                    cross.merge(stages);
                }
            }
        }
        self.ops_same_host = (same.ops > 0).then(|| same.summary());
        self.ops_cross_host = (cross.ops > 0).then(|| cross.summary());
    }
}

/// What the report says a simulated host is when no network namespace could be made.
pub const SIMULATED_AS: &str =
    "separate iceoryx2 prefixes on one machine (no network namespaces), Redis over loopback";

/// The bridges of a run, started. Field order matters on drop: bridges end before their relays
/// and namespaces go.
pub(super) struct Bridges {
    hosts: Vec<String>,
    children: Vec<Child>,
    readers: Vec<JoinHandle<Option<BridgeReport>>>,
    layout: Vec<String>,
    simulated_as: String,
    /// A relay on loopback for a delayed host when there are no namespaces.
    _loopback_relay: Option<Relay>,
    namespaces: Option<Namespaces>,
}

/// How long a bridge may take to open its transports.
const READY_TIMEOUT: Duration = Duration::from_secs(20);

impl Bridges {
    /// The host of each cluster of `scene` and, on more than one host, each host's bridge
    /// started and listening. `None` for a run on one host.
    pub(super) fn start(plan: &RunPlan, scene: &Scene) -> BenchResult<Option<Self>> {
        let layout = scene.host_layout(plan.hosts.count)?;
        let mut hosts = layout.clone();
        hosts.dedup();
        hosts.sort();
        hosts.dedup();
        if hosts.len() < 2 {
            return Ok(None);
        }
        let program = plan
            .node_command
            .first()
            .ok_or_else(|| BenchError::process("seam", "no command to start a bridge"))?;
        if let Some(delayed) = &plan.hosts.delayed_host
            && !hosts.contains(delayed)
        {
            return Err(BenchError::flag(
                "--delayed-host",
                format!("{delayed:?}: the run's hosts are {}", hosts.join(", ")),
            ));
        }
        let delayed_host = plan
            .hosts
            .delayed_host
            .clone()
            .or_else(|| hosts.last().cloned())
            .unwrap_or_default();
        let delay =
            (!plan.hosts.delay.is_none()).then_some((delayed_host.as_str(), plan.hosts.delay));
        let tag = format!(
            "{:x}",
            (std::process::id() ^ run_salt(&plan.run_id)) & 0xff_ffff
        );
        let namespaces = if plan.hosts.namespaces {
            Namespaces::create(&tag, &hosts, &plan.hosts.redis, delay)
        } else {
            Err(BenchError::flag("--no-namespaces", "namespaces turned off"))
        };
        let (namespaces, simulated_as, loopback_relay) = match namespaces {
            Ok(made) => {
                let described = made.describe();
                (Some(made), described, None)
            }
            Err(why) => {
                let relay = match delay {
                    Some((_, delay)) => Some(loopback_relay(&plan.hosts.redis, delay)?),
                    None => None,
                };
                (None, format!("{SIMULATED_AS}: {why}"), relay)
            }
        };
        if namespaces.is_none() {
            tracing::warn!("seam run --hosts: {simulated_as}");
        }
        let mut bridges = Self {
            hosts: Vec::new(),
            children: Vec::new(),
            readers: Vec::new(),
            layout,
            simulated_as,
            _loopback_relay: loopback_relay,
            namespaces,
        };
        for host in &hosts {
            bridges.start_one(plan, host, program, delay)?;
        }
        Ok(Some(bridges))
    }

    /// Starts the bridge of `host` with `program` and waits until it is ready; `delay` is
    /// the delayed host and its delay, if any.
    fn start_one(
        &mut self,
        plan: &RunPlan,
        host: &str,
        program: &std::ffi::OsStr,
        delay: Option<(&str, Delay)>,
    ) -> BenchResult<()> {
        let redis = match (&self.namespaces, &self._loopback_relay, delay) {
            (Some(ns), ..) => ns.redis_url(host, &plan.hosts.redis),
            (None, Some(relay), Some((delayed, _))) if delayed == host => {
                redirect(&plan.hosts.redis, relay.addr())
            }
            _ => plan.hosts.redis.clone(),
        };
        let mut command = self.command(host, program);
        command
            .arg("bridge")
            .arg(&plan.scene)
            .args(["--host", host])
            .args(["--run-id", &plan.run_id])
            .args(["--local", &host_url(&plan.transport, host)?])
            // Through the environment: the URL may hold a password.
            .env("SEAM_REDIS", &redis)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        if let Some(n) = plan.hosts.count {
            command.args(["--hosts", &n.to_string()]);
        }
        let mut child = command
            .spawn()
            .map_err(|e| BenchError::io("start", format!("the bridge of host {host:?}"), e))?;
        let stdout = child.stdout.take().ok_or_else(|| {
            BenchError::process(format!("the bridge of host {host:?}"), "no stdout")
        })?;
        self.children.push(child);
        self.hosts.push(host.to_owned());
        let (ready, ready_rx) = mpsc::channel();
        self.readers
            .push(std::thread::spawn(move || read_lines(stdout, ready)));
        match ready_rx.recv_timeout(READY_TIMEOUT) {
            Ok(()) => {}
            Err(_) => {
                return Err(BenchError::Timeout {
                    what: format!(
                        "the bridge of host {host:?} did not get ready (its error is above)"
                    ),
                    waited: READY_TIMEOUT,
                });
            }
        }
        Ok(())
    }

    /// The transport URL of the pod of cluster number `index`.
    pub(super) fn pod_url(&self, plan: &RunPlan, index: usize) -> BenchResult<String> {
        host_url(&plan.transport, &self.layout[index])
    }

    /// The network namespace the pod of cluster number `index` runs in, if hosts are
    /// namespaces.
    pub(super) fn pod_namespace(&self, index: usize) -> Option<&str> {
        self.namespaces.as_ref()?.name(&self.layout[index])
    }

    /// A command running `program` on `host` (inside its namespace, if it has one).
    fn command(&self, host: &str, program: &std::ffi::OsStr) -> Command {
        in_namespace(self.namespaces.as_ref().and_then(|n| n.name(host)), program)
    }

    /// Stops every bridge and gathers their reports.
    pub(super) fn finish(mut self) -> BenchResult<HostsSummary> {
        self.signal_all();
        let mut bridges = Vec::new();
        let mut problems = Vec::new();
        for ((host, mut child), reader) in self
            .hosts
            .drain(..)
            .zip(std::mem::take(&mut self.children))
            .zip(std::mem::take(&mut self.readers))
        {
            let status = child.wait().map_err(|e| {
                BenchError::io("wait for", format!("the bridge of host {host:?}"), e)
            })?;
            match reader.join().ok().flatten() {
                Some(report) if status.success() => bridges.push(report),
                _ => problems.push(format!(
                    "the bridge of host {host:?} exited with {status} and no report (its error is above)"
                )),
            }
        }
        if !problems.is_empty() {
            return Err(BenchError::process("bridges", problems.join("\n")));
        }
        Ok(HostsSummary {
            simulated_as: std::mem::take(&mut self.simulated_as),
            layout: std::mem::take(&mut self.layout),
            bridges,
            ops_same_host: None,
            ops_cross_host: None,
        })
    }

    fn signal_all(&mut self) {
        for child in &mut self.children {
            if let Ok(None) = child.try_wait()
                && let Some(pid) = rustix::process::Pid::from_raw(child.id() as i32)
            {
                let _ = rustix::process::kill_process(pid, rustix::process::Signal::TERM);
            }
        }
    }
}

impl Drop for Bridges {
    fn drop(&mut self) {
        for child in &mut self.children {
            if let Ok(None) = child.try_wait() {
                let _ = child.kill();
                let _ = child.wait();
            }
        }
    }
}

/// Reads a bridge's lines: says when it is ready, returns its report.
fn read_lines(stdout: std::process::ChildStdout, ready: mpsc::Sender<()>) -> Option<BridgeReport> {
    let mut report = None;
    for line in BufReader::new(stdout).lines() {
        let Ok(line) = line else { break };
        match serde_json::from_str::<BridgeLine>(&line) {
            Ok(BridgeLine::Ready { .. }) => {
                let _ = ready.send(());
            }
            Ok(BridgeLine::Report(r)) => report = Some(r),
            Err(_) => {}
        }
    }
    report
}

/// A command running `program`, inside network namespace `namespace` if given.
pub(super) fn in_namespace(namespace: Option<&str>, program: &std::ffi::OsStr) -> Command {
    match namespace {
        Some(name) => {
            let mut command = Command::new("ip");
            command.args(["netns", "exec", name]).arg(program);
            command
        }
        None => Command::new(program),
    }
}

/// A relay on loopback in front of the Redis server of `redis`, delaying by `delay`.
fn loopback_relay(redis: &str, delay: Delay) -> BenchResult<Relay> {
    let upstream = super::netns::redis_addr(redis)?;
    let any = std::net::SocketAddr::new(std::net::Ipv4Addr::LOCALHOST.into(), 0);
    Relay::start(any, upstream, delay)
}

/// A few bits of the run id, so concurrent runs of one process name their namespaces apart.
fn run_salt(run_id: &str) -> u32 {
    run_id
        .bytes()
        .fold(0u32, |h, b| h.wrapping_mul(31).wrapping_add(u32::from(b)))
}
