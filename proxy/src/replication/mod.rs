//! Replication: each cluster's states out every `replication_interval` ticks, and the
//! neighbours' states in, as proxies of what this cluster models.
//!
//! # Layout
//!
//! - `publish` — [`Publisher`]: this cluster's frame, with its hand-offs, as a keyframe or a
//!   delta frame.
//! - `keyframes` — which frames are keyframes, and what a delta frame leaves out.
//! - `keys` — [`Keys`]: each neighbour's last keyframe, to read its delta frames against.
//! - `interest` — [`Interest`]: which neighbour entities are modelled ([`extent`] against the
//!   region and the room around this cluster's own bodies).
//! - `reconcile` — [`Reconcile`]: the world brought in line with a neighbour's frame.
//! - `proxies` — [`Proxies`]: how a proxy follows its entity ([`CustomProxy`]).
//! - `dead_reckoning` — where a kinematic proxy aims between frames.

mod dead_reckoning;
mod interest;
mod keyframes;
mod keys;
mod proxies;
mod publish;
mod reconcile;

pub(crate) use interest::Interest;
pub use interest::extent;
pub(crate) use keys::Keys;
pub use proxies::CustomProxy;
pub(crate) use proxies::Proxies;
pub(crate) use publish::{FrameHandoffs, Publisher};
pub(crate) use reconcile::Reconcile;
