//! How a cluster is configured to decide hand-offs: [`AuthorityMode`].

use super::spatial::SpatialSettings;

/// How a cluster decides hand-offs besides those game code asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AuthorityMode {
    /// Only scripted hand-offs ([`Cluster::transfer_authority`](crate::Cluster)).
    Scripted,
    /// [`Spatial`](super::Spatial) with these settings (the default). Needs the neighbours' regions from
    /// `ClusterConfig::world`; without them nothing is handed over.
    Spatial(SpatialSettings),
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
        AuthorityMode::spatial()
    }
}
