//! When each stage of one routed op happened: [`OpTiming`], carried by
//! [`ClusterEvent::OpApplied`](super::ClusterEvent::OpApplied).

use seam_sim::wire::{ClusterId, EntityId};

/// When each stage of one routed op happened, host monotonic nanoseconds (see
/// [`monotonic_ns`](crate::monotonic_ns)), and in which ticks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OpTiming {
    /// The cluster whose physics-events frame brought it (its issuer, or the former owner
    /// that forwarded it).
    pub from: ClusterId,
    /// The entity the op wrote to.
    pub target: EntityId,
    /// User code made the write (issuing cluster).
    pub issued_ns: u64,
    /// The frame carrying it was handed to the transport (issuing cluster).
    pub published_ns: u64,
    /// The owner took the frame from its transport.
    pub received_ns: u64,
    /// The owner applied the op, just before its step.
    pub applied_ns: u64,
    /// The issuing cluster's tick at the write.
    pub issued_tick: u64,
    /// The owner's tick when it applied the op.
    pub applied_tick: u64,
}
