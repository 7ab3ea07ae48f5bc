//! seam-sim — one cluster's physics: a Rapier world keyed by entity, and the wire types clusters
//! exchange. It knows nothing of transports or of other clusters beyond each entity's
//! `cluster_id`.
//!
//! ```
//! use seam_sim::{BodyRole, ClusterSim, LocalOnly, SimConfig};
//! use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, Shape};
//!
//! let here = ClusterId::random();
//! let mut sim = ClusterSim::new(SimConfig::new(here));
//! let ball = EntityId::random();
//! sim.spawn(
//!     &EntityState {
//!         id: ball,
//!         cluster_id: here,
//!         tick: 0,
//!         epoch: 0,
//!         position: [0.0, 10.0, 0.0],
//!         rotation: [0.0, 0.0, 0.0, 1.0],
//!         linvel: [0.0; 3],
//!         angvel: [0.0; 3],
//!         body: BodySpec::new(Shape::Ball { radius: 0.5 }).density(1.0),
//!     },
//!     BodyRole::Dynamic,
//! )?;
//! // User code runs with a tick context and an entity-keyed handle, then the world steps.
//! sim.run_user(&mut LocalOnly, |_context, physics| {
//!     physics.apply_impulse(ball, [1.0, 0.0, 0.0]).map(|_| ())
//! })?;
//! sim.step();
//! assert!(sim.state(ball).expect("spawned").linvel[0] > 0.0);
//! # Ok::<(), seam_sim::SimError>(())
//! ```
//!
//! # Layout
//!
//! - [`wire`] — ids, [`wire::EntityState`], [`wire::ReplicationFrame`],
//!   [`wire::PhysicsEventsFrame`], [`wire::PhysicsOp`]; postcard behind a version byte, safe on
//!   untrusted bytes.
//! - `cluster_sim` — [`ClusterSim`]: the world, spawning and despawning from states, roles
//!   changed in place, stepping.
//! - `config` — [`SimConfig`]: step length, gravity, the speed cap.
//! - `entity` — [`BodyRole`] and [`EntityInfo`]: what the world knows of an entity besides
//!   its body.
//! - `handle` — [`TickContext`], [`PhysicsHandle`] (reads, raycasts, shape queries, writes).
//! - `joints` — [`JointSpec`], [`JointId`]: joints between entities this cluster owns.
//! - `router` — [`WriteRouter`], the hook through which the proxy layer routes writes on
//!   entities owned elsewhere, and [`LocalOnly`].
//! - `body` — Rapier bodies and colliders behind entities.
//! - [`shapes`] — [`ShapeCatalog`]: convex hulls, compounds, triangle meshes and heightfields
//!   every cluster registers, named on the wire by content hash.
//! - `contacts` — Rapier collision events as entity pairs with impulse and normal
//!   ([`ContactEvent`]).
//! - [`box_grid`] — boxes filed in a grid, for overlap queries without Rapier.
//! - [`coupling`] — proxies that meet this cluster's bodies with their entity's own mass, so a
//!   contact across the seam pushes both ways.
//! - `touching` — which bodies touch around the seam (what a group authority policy binds).
//! - `validate` — NaN, infinity, rotation and shape checks before anything reaches Rapier.
//! - `error` — [`SimError`].
//!
//! Determinism: Rapier is built with `enhanced-determinism`, and entities are kept in a map with
//! a fixed hasher, so the same inputs in the same order give bit-identical worlds.

mod body;
pub mod box_grid;
mod cluster_sim;
mod config;
mod contacts;
pub mod coupling;
mod entity;
mod error;
mod handle;
mod joints;
mod router;
pub mod shapes;
mod touching;
mod validate;
pub mod wire;

pub use cluster_sim::{ClusterSim, PairCensus};
pub use config::SimConfig;
pub use contacts::ContactEvent;
pub use coupling::{CouplingChanges, SeamImpulse};
pub use entity::{BodyRole, EntityInfo};
pub use error::SimError;
pub use handle::{PhysicsHandle, RayHit, TickContext};
pub use joints::{JointId, JointSpec};
pub use router::{LocalOnly, WriteOutcome, WriteRouter};
pub use shapes::{Part, ShapeCatalog, ShapeDef};
pub use touching::Touching;
pub use validate::check_state;
