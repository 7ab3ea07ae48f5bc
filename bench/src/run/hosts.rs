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

use crate::bridge::{BridgeLine, BridgeReport, host_url};
use crate::scene::Scene;

use super::RunPlan;

/// How `seam run` lays pods out on hosts.
#[derive(Debug, Clone)]
pub struct HostsPlan {
    /// Simulated hosts for a scene whose clusters name none (`None`: the scene's, or one).
    pub count: Option<u32>,
    /// The Redis server between hosts.
    pub redis: String,
}

impl Default for HostsPlan {
    fn default() -> Self {
        Self {
            count: None,
            redis: "redis://127.0.0.1:6379".to_owned(),
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
}

/// What the report says a simulated host is.
pub const SIMULATED_AS: &str =
    "separate iceoryx2 prefixes on one machine (no network namespaces), Redis over loopback";

/// The bridges of a run, started.
pub(super) struct Bridges {
    hosts: Vec<String>,
    children: Vec<Child>,
    readers: Vec<JoinHandle<Option<BridgeReport>>>,
    layout: Vec<String>,
}

/// How long a bridge may take to open its transports.
const READY_TIMEOUT: Duration = Duration::from_secs(20);

impl Bridges {
    /// The host of each cluster of `scene` and, on more than one host, each host's bridge
    /// started and listening. `None` for a run on one host.
    pub(super) fn start(plan: &RunPlan, scene: &Scene) -> Result<Option<Self>, String> {
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
            .ok_or("no command to start a bridge")?;
        let mut bridges = Self {
            hosts: Vec::new(),
            children: Vec::new(),
            readers: Vec::new(),
            layout,
        };
        for host in &hosts {
            let mut command = Command::new(program);
            command
                .arg("bridge")
                .arg(&plan.scene)
                .args(["--host", host])
                .args(["--run-id", &plan.run_id])
                .args(["--local", &host_url(&plan.transport, host)?])
                // Through the environment: the URL may hold a password.
                .env("SEAM_REDIS", &plan.hosts.redis)
                .stdin(Stdio::null())
                .stdout(Stdio::piped())
                .stderr(Stdio::inherit());
            if let Some(n) = plan.hosts.count {
                command.args(["--hosts", &n.to_string()]);
            }
            let mut child = command
                .spawn()
                .map_err(|e| format!("cannot start the bridge of host {host:?}: {e}"))?;
            let stdout = child.stdout.take().ok_or("the bridge has no stdout")?;
            bridges.children.push(child);
            bridges.hosts.push(host.clone());
            let (ready, ready_rx) = mpsc::channel();
            bridges
                .readers
                .push(std::thread::spawn(move || read_lines(stdout, ready)));
            match ready_rx.recv_timeout(READY_TIMEOUT) {
                Ok(()) => {}
                Err(_) => {
                    return Err(format!(
                        "the bridge of host {host:?} did not get ready within {} s (its error is above)",
                        READY_TIMEOUT.as_secs()
                    ));
                }
            }
        }
        Ok(Some(bridges))
    }

    /// The transport URL of the pod of cluster number `index`.
    pub(super) fn pod_url(&self, plan: &RunPlan, index: usize) -> Result<String, String> {
        host_url(&plan.transport, &self.layout[index])
    }

    /// Stops every bridge and gathers their reports.
    pub(super) fn finish(mut self) -> Result<HostsSummary, String> {
        self.signal_all();
        let mut bridges = Vec::new();
        let mut problems = Vec::new();
        for ((host, mut child), reader) in self
            .hosts
            .drain(..)
            .zip(std::mem::take(&mut self.children))
            .zip(std::mem::take(&mut self.readers))
        {
            let status = child.wait().map_err(|e| format!("bridge {host:?}: {e}"))?;
            match reader.join().ok().flatten() {
                Some(report) if status.success() => bridges.push(report),
                _ => problems.push(format!(
                    "the bridge of host {host:?} exited with {status} and no report (its error is above)"
                )),
            }
        }
        if !problems.is_empty() {
            return Err(problems.join("\n"));
        }
        Ok(HostsSummary {
            simulated_as: SIMULATED_AS.to_owned(),
            layout: std::mem::take(&mut self.layout),
            bridges,
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
