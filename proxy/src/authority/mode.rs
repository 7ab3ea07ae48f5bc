//! How a cluster is configured to decide hand-offs: [`AuthorityMode`].

use super::group::GroupSettings;
use super::spatial::SpatialSettings;

/// How a cluster decides hand-offs besides those game code asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AuthorityMode {
    /// Only scripted hand-offs ([`Cluster::transfer_authority`](crate::Cluster)).
    Scripted,
    /// [`Spatial`](super::Spatial) with these settings. Needs the neighbours' regions from
    /// `ClusterConfig::world`; without them nothing is handed over.
    Spatial(SpatialSettings),
    /// [`Group`](super::Group) with these settings (the default, with
    /// [`GroupSettings::default`]): bodies in sustained contact share one owner where three
    /// or more clusters' bodies meet, the rest follow the spatial rule. Needs the world map as
    /// `Spatial` does.
    Group(GroupSettings),
    /// A policy set with [`Cluster::set_authority_policy`](crate::Cluster) (none set: scripted).
    Custom,
}

impl AuthorityMode {
    /// [`Spatial`](super::Spatial) with its default settings.
    pub fn spatial() -> Self {
        AuthorityMode::Spatial(SpatialSettings::default())
    }
}

impl Default for AuthorityMode {
    fn default() -> Self {
        AuthorityMode::Group(GroupSettings::default())
    }
}
