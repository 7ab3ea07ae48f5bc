//! seam-proxy — the three layers that make physics work across the seam between clusters,
//! joining a `seam-sim` world to any `seam-transport` backend.
//!
//! Not built yet (issue 4). It will hold:
//!
//! # Layout
//!
//! - `cluster` — `Cluster` and `ClusterConfig`: one tick is drain inbox → reconcile → user
//!   `on_tick` → apply routed ops → step → publish.
//! - `proxies` — layer 1: neighbour entities as Fixed or kinematic bodies.
//! - `routing` — layer 2: writes on remote-owned entities batched per owner; contacts reported
//!   back to the proxy's owner.
//! - `authority` — layer 3: ownership moves by flipping `cluster_id` in the replication frame.
//! - `lockstep` — a harness that steps N clusters tick by tick, waiting on frame counts.
