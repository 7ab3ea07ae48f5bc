//! Who should own an entity: the policy an owner asks at each replication frame.
//!
//! An owner hands an entity over by [`Cluster::transfer_authority`](crate::Cluster) (scripted:
//! game code decides) or because its [`AuthorityPolicy`] says so — the hook where an affinity
//! system plugs in. The policy is asked at every replication frame with the bodies the
//! cluster owns, their roles and states, and names the hand-offs to make in that frame; the cluster
//! makes those that are valid (to a live neighbour) and that no scripted hand-off already
//! claims.
//!
//! The built-in [`Spatial`] policy makes authority follow its entities through the world:
//!
//! > An entity whose centre — where its velocity carries it by the next replication frame — is
//! > more than `margin` outside its owner's region is handed to the live neighbour whose
//! > region holds that point at least `margin` deep; if none does (a fast body that overshot a
//! > neighbour, or one that left every region), to the live neighbour whose region is nearest
//! > to it, if that is nearer than the owner's by more than `margin`. The same answer must
//! > hold `dwell_ticks` frames in a row.
//!
//! Looking ahead matters for fast bodies: the step in which a shot crosses a seam is then
//! simulated by the cluster it enters, which owns what it is about to hit there (a shot
//! handed over only after it crossed has already met the next region's bodies as proxies in
//! its old owner's world). For slow bodies the look-ahead is a few millimetres.
//!
//! The margin is the hysteresis: a body resting on a seam, or jittering across it, stays where
//! it is, and one handed over must come back `margin` deep before it returns. Ownership goes by
//! the centre, not the extent (`crate::replication`): a body lies in one region by its centre,
//! while its extent can reach into several, and the owner models the room around a body of
//! its that is outside its region, so nothing is missed while it is within the margin.
//!
//! The defaults — a margin of 0.25 m, one frame — were chosen by measurement on the bundled
//! scenes (`seam compare SCENE --ticks 600 --handoff-margin M --handoff-dwell D`): a dwell of 3
//! frames hands `crossfire`'s shot to the targets' cluster too late (hit recall 0.667 against
//! 1.000, and a 2.5 m/s jump at the hand-off); a margin of 1 m leaves crates resting just past
//! the seam with the cluster that does not model what lies beyond them (`stacks`: RMS 3.3 cm
//! against 1.5 cm); below 0.25 m a ball pressed against the seam on `grid` changes hands back
//! and forth (3 hand-offs at 0 m, 1 at 0.1 m, none at 0.25–1 m), each without gain. Margins
//! from 0 to 0.5 m and a dwell of 1 leave every other figure as it is.
//!
//! `Spatial` hands the bodies that move: dynamic ones, and kinematic ones their owner moves
//! through their velocity (platforms, elevators), which keep that role and velocity at the new
//! owner (the wire carries how the owner moves a body, `Motion`). A Fixed body stays with its
//! owner.
//!
//! The default policy is [`Group`]: the spatial rule, but bodies in sustained contact where
//! three or more clusters' bodies meet share one owner (see `group` for the rule). Two
//! clusters solve a contact between their bodies alike (coupling, and settling what each
//! world gave its own body); where three or four meet — a stack on the corner point whose
//! crates four clusters own — each world solves the whole stack with a different part of it
//! its own, pairwise settling cannot reconcile them, and the stack is pushed apart. Measured
//! in lock-step (`seam compare SCENE --authority spatial|group [--group-min-owners N]`):
//! `open/corner` 13.8 m RMS with the spatial rule against a floor of 3.9 m (onset tick 68
//! against 89), 5.5 m with groups (onset 94: at the floor); every two-cluster scene the same
//! either way; `grid` 0.318 → 0.325 m (floor 0.655), its split tick about 10 % dearer
//! (2.53–2.59 times one world's against 2.30–2.34: the contacts walked from each moving proxy
//! every frame, and 27 hand-offs against 7). A group is given one owner only while its
//! bodies rest against its anchor (0.5 m/s): a stack toppling at a corner handed over
//! mid-collision ended 1.02 m from one world against a floor of 0.21 m
//! (`bench/scenes/variants/corner-topple.toml`; 0.20 m with the rule). Giving one owner
//! to every group across a seam (`min_owners` 2) helps no bundled scene further and costs
//! `grid` 800 hand-offs of balls in its piles, `seam-stack` 0.5 → 1.2 cm.
//! Where the cluster knows of fewer clusters than `min_owners` (two clusters, groups where
//! three meet), no group can be given one owner, so no contacts are walked at all: on two
//! `grid` pods that halved the publish phase (BENCHMARKS.md, "The group walk only where
//! groups can form").
//!
//! A body is handed to a cluster that already holds a proxy of it, but for one case, on
//! purpose: the spatial rule hands a body whose centre will be in the neighbour's region by
//! the next frame, so the neighbour's interest (its region grown by its spread, and each
//! extent swept to the next frame) held it in the frame before — unless the body is new: a
//! shot fired this tick that crosses by the next frame is handed in its first frame, since
//! waiting a frame for the neighbour to model it would have the shooter simulate the crossing
//! step against proxies. The taker then spawns it from the hand-off's state, counted in
//! `ClusterStats::handoffs_in_without_proxy` (and in `seam compare`'s hand-offs line):
//! lock-step at default settings, `gallery` 59 (its shots), `crossfire` 1 (its 400 m/s shot),
//! `open/corner` 1, every other bundled scene 0. (The giver cannot check the taker's interest:
//! its spread and watched boxes are the taker's own.)
//!
//! Who adopts a dead neighbour's entities is the other authority rule (`adoption`).

pub(crate) mod adoption;
mod group;
mod mode;
mod policy;
mod spatial;

pub use group::{Group, GroupSettings};
pub use mode::AuthorityMode;
pub use policy::{AuthorityPolicy, AuthorityView, NeighbourView, Touching};
pub use spatial::{Spatial, SpatialSettings};
