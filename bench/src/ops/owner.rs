//! The owning side of `seam ops` (a child process).

use seam_proxy::monotonic_ns;
use seam_sim::wire::{self, BodySpec, EntityState, PhysicsEventsFrame, Shape};
use seam_sim::{BodyRole, ClusterSim, SimConfig};

use super::{StageReport, TARGET};
use crate::error::BenchResult;
use crate::latency::LatencyRecorder;
use crate::wait::{WaitMode, next_message};

/// What the issuer sends when it is done.
pub(super) const STOP: &[u8] = b"stop";

/// Applies every op of every frame on `events` at once, acknowledges each frame on `ack`, and at
/// the end prints the stage report as one JSON line.
pub fn run_owner(url: &str, events: &str, ack: &str, wait: WaitMode) -> BenchResult<()> {
    let mut transport = seam_transport::open(url)?;
    transport.subscribe(events)?;
    let here = seam_sim::wire::ClusterId::random();
    let mut sim = ClusterSim::new(SimConfig {
        gravity: [0.0; 3],
        ..SimConfig::new(here)
    });
    sim.spawn(
        &EntityState::new(TARGET, here, BodySpec::new(Shape::ball(0.5))),
        BodyRole::Dynamic,
    )?;
    transport.publish(ack, b"ready")?;
    let (mut whole, mut queue, mut transport_stage, mut apply) = (
        LatencyRecorder::default(),
        LatencyRecorder::default(),
        LatencyRecorder::default(),
        LatencyRecorder::default(),
    );
    let mut ops = 0;
    let mut buf = Vec::new();
    loop {
        next_message(transport.as_mut(), wait, &mut buf)?;
        let received_ns = monotonic_ns();
        if buf == STOP {
            break;
        }
        let frame: PhysicsEventsFrame = wire::decode(&buf)?;
        for routed in &frame.ops {
            sim.apply_op(&routed.op)?;
            let applied_ns = monotonic_ns();
            if frame.tick == 1 {
                ops += 1;
                whole.record(applied_ns.saturating_sub(routed.issued_ns));
                queue.record(frame.published_ns.saturating_sub(routed.issued_ns));
                transport_stage.record(received_ns.saturating_sub(frame.published_ns));
                apply.record(applied_ns.saturating_sub(received_ns));
            }
        }
        transport.publish(ack, b"ok")?;
    }
    let report = StageReport {
        ops,
        whole: whole.summary(),
        queue: queue.summary(),
        transport: transport_stage.summary(),
        apply: apply.summary(),
    };
    println!("{}", serde_json::to_string(&report)?);
    Ok(())
}
