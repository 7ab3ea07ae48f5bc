//! The hook an owner asks for hand-offs: [`AuthorityPolicy`], what it sees
//! ([`AuthorityView`]) and how a cluster is configured to use one ([`AuthorityMode`]).

use seam_sim::BodyRole;
use seam_sim::wire::{ClusterId, EntityId, EntityState};

use crate::world::Region;

/// What a policy sees at one replication frame.
pub struct AuthorityView<'a> {
    /// The asking cluster (the owner).
    pub cluster: ClusterId,
    /// Its tick.
    pub tick: u64,
    /// Its region.
    pub region: Region,
    /// Seconds until the next replication frame (`dt` × `replication_interval`): a hand-off
    /// made now takes effect at the next step, and the next chance to make one is that far
    /// away.
    pub lookahead_s: f32,
    /// Its neighbours: the only clusters it can hand to.
    pub neighbours: &'a [NeighbourView],
    /// The entities it owns, with their states (as its replication frame carries them) and
    /// roles.
    pub owned: &'a [(EntityState, BodyRole)],
    /// The bodies touching in its world now around its neighbours' moving bodies, each pair
    /// with their owners (empty unless the policy asks for them,
    /// [`AuthorityPolicy::touching_budget`]).
    pub touching: &'a [Touching],
}

pub use seam_sim::Touching;

/// A neighbour, as a policy sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeighbourView {
    /// The neighbour.
    pub id: ClusterId,
    /// Its region, if the cluster was told it (`ClusterConfig::world`).
    pub region: Option<Region>,
    /// Whether it is taken for alive (hand-offs to a neighbour taken for dead are refused).
    pub alive: bool,
}

/// Decides hand-offs for the owner. See the module docs.
pub trait AuthorityPolicy {
    /// Appends to `handoffs` the entities to hand over in this frame, and to whom.
    fn decide(&mut self, view: &AuthorityView<'_>, handoffs: &mut Vec<(EntityId, ClusterId)>);

    /// How many bodies the policy wants [`AuthorityView::touching`] walked, from each of the
    /// neighbours' bodies that move in this world, along contacts (0, the default: it does
    /// not read it, and the contacts are not walked). `clusters` is how many clusters this one
    /// knows of, itself included (its neighbours and its world map): the most owners the
    /// bodies it sees touching can have.
    fn touching_budget(&self, clusters: usize) -> usize {
        let _ = clusters;
        0
    }
}
