//! The host's monotonic clock as plain nanoseconds.
//!
//! Routed ops are stamped with it in one process and compared with it in another, so it must be
//! one clock for every process of the host: `CLOCK_MONOTONIC`. (`std::time::Instant` reads the
//! same clock but does not expose its value.) Stamps from different hosts cannot be compared.

/// Nanoseconds of `CLOCK_MONOTONIC`.
pub fn monotonic_ns() -> u64 {
    let now = rustix::time::clock_gettime(rustix::time::ClockId::Monotonic);
    now.tv_sec as u64 * 1_000_000_000 + now.tv_nsec as u64
}

/// When each stage of one routed op happened, host monotonic nanoseconds, and in which ticks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OpTiming {
    /// The cluster whose physics-events frame brought it (its issuer, or the former owner
    /// that forwarded it).
    pub from: seam_sim::wire::ClusterId,
    /// The entity the op wrote to.
    pub target: seam_sim::wire::EntityId,
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
