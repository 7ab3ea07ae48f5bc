//! seam-sim — one cluster's physics, knowing nothing of transports or of other clusters beyond
//! each entity's `cluster_id`.
//!
//! Not built yet (issue 3). It will hold:
//!
//! # Layout
//!
//! - `wire` — `EntityId`, `ClusterId`, `EntityState`, `ReplicationFrame`, `PhysicsEventsFrame`
//!   and `PhysicsOp`, postcard-encoded behind a format version; decoding untrusted bytes never
//!   panics.
//! - `cluster_sim` — `ClusterSim`: one Rapier world with a map entity → body, bodies that change
//!   role in place (dynamic, Fixed, kinematic), deterministic stepping.
//! - `handle` — the tick context and `PhysicsHandle`: entity-keyed reads, queries and writes,
//!   validated (no NaN, no unknown entity), with a hook that lets the proxy layer route writes on
//!   entities owned elsewhere.
