//! [`PairCensus`]: what Rapier's narrow phase holds at one moment, split by whether the
//! bodies are this cluster's or proxies — the share of its step that the seam adds.

use rapier3d::prelude::ColliderHandle;
use serde::{Deserialize, Serialize};

use super::ClusterSim;
use crate::wire::{ClusterId, EntityId};

/// The narrow phase's pairs after a step: every pair the broad phase found (each costs a
/// narrow-phase test), those touching (each a solver constraint, with its contact points),
/// and how many of each involve a proxy (a body another cluster owns), or only proxies.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PairCensus {
    /// Pairs in the narrow phase.
    pub pairs: u64,
    /// Of those, with a proxy on at least one side.
    pub pairs_with_proxy: u64,
    /// Of those, with proxies on both sides.
    pub pairs_between_proxies: u64,
    /// Pairs touching (at least one active contact).
    pub touching: u64,
    /// Of those, with a proxy on at least one side.
    pub touching_with_proxy: u64,
    /// Of those, with proxies on both sides (coupled proxies, dynamic for the step).
    pub touching_between_proxies: u64,
    /// Active contact points, the solver's work.
    pub contacts: u64,
    /// Of those, in pairs with a proxy.
    pub contacts_with_proxy: u64,
}

impl PairCensus {
    /// Adds `other`'s counts to these (to average several).
    pub fn add(&mut self, other: &PairCensus) {
        self.pairs += other.pairs;
        self.pairs_with_proxy += other.pairs_with_proxy;
        self.pairs_between_proxies += other.pairs_between_proxies;
        self.touching += other.touching;
        self.touching_with_proxy += other.touching_with_proxy;
        self.touching_between_proxies += other.touching_between_proxies;
        self.contacts += other.contacts;
        self.contacts_with_proxy += other.contacts_with_proxy;
    }
}

impl ClusterSim {
    /// Counts the narrow phase's pairs now (one pass over them, two entity lookups each: a
    /// measurement, not for every tick). Scenery counts as this cluster's.
    pub fn pair_census(&self) -> PairCensus {
        let me = self.config.cluster_id;
        let proxy = |h: ColliderHandle| {
            let owner = (self.world.colliders.get(h))
                .map(|c| EntityId::from_u128(c.user_data))
                .and_then(|id| self.entities.get(&id))
                .map(|entry| entry.info.owner);
            owner.is_some_and(|o| o != me && o != ClusterId::SCENERY)
        };
        let mut census = PairCensus::default();
        for pair in self.world.narrow_phase.contact_pairs() {
            let proxies = u64::from(proxy(pair.collider1)) + u64::from(proxy(pair.collider2));
            census.pairs += 1;
            census.pairs_with_proxy += u64::from(proxies > 0);
            census.pairs_between_proxies += u64::from(proxies == 2);
            if pair.has_any_active_contact() {
                let points: usize = (pair.manifolds().iter())
                    .map(|m| m.data.num_active_contacts())
                    .sum();
                census.touching += 1;
                census.touching_with_proxy += u64::from(proxies > 0);
                census.touching_between_proxies += u64::from(proxies == 2);
                census.contacts += points as u64;
                if proxies > 0 {
                    census.contacts_with_proxy += points as u64;
                }
            }
        }
        census
    }
}
