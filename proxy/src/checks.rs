//! The rules a [`ClusterConfig`] must meet, checked when a cluster is made
//! ([`ClusterConfig::check`], called by `Cluster::new`): a value that would freeze every body,
//! fail later with an error blaming someone else, or be quietly ignored is refused at once with
//! an error naming the field, the value and the rule. docs/operations.md lists them.

use seam_sim::wire::{ClusterId, EntityId};

use crate::config::ClusterConfig;
use crate::world::Region;

/// A configuration value that breaks a rule.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{field}` = {value}: {rule}")]
pub struct ConfigError {
    /// The field (`ClusterConfig`'s name for it; `world[i].region` for a world-map entry).
    pub field: String,
    /// The value given.
    pub value: String,
    /// The rule it breaks.
    pub rule: &'static str,
}

/// Checks the names of clusters and entities.
fn names(c: &ClusterConfig) -> Result<(), ConfigError> {
    for (id, name) in &c.names {
        if !name_ok(name) {
            return Err(refuse(
                format!("names[{id}]"),
                name,
                "a cluster's name is 1 to 64 printable characters",
            ));
        }
    }
    for (&id, name) in &c.entity_names {
        entity_name(id, name)?;
    }
    Ok(())
}

/// Whether `name` is 1 to 64 printable characters, not all blank: the rule for the names of
/// clusters and entities (`ClusterConfig::names`, `ClusterConfig::entity_names`).
pub fn name_ok(name: &str) -> bool {
    !name.trim().is_empty() && name.len() <= 64 && !name.chars().any(char::is_control)
}

/// Checks an entity's name (see `ClusterConfig::entity_names`).
pub(crate) fn entity_name(id: EntityId, name: &str) -> Result<(), ConfigError> {
    if name_ok(name) {
        Ok(())
    } else {
        Err(refuse(
            format!("entity_names[{id}]"),
            name,
            "an entity's name is 1 to 64 printable characters",
        ))
    }
}

fn refuse(
    field: impl Into<String>,
    value: impl std::fmt::Debug,
    rule: &'static str,
) -> ConfigError {
    ConfigError {
        field: field.into(),
        value: format!("{value:?}"),
        rule,
    }
}

impl ClusterConfig {
    /// Whether every field meets its rule (see docs/operations.md, "Configuration rules");
    /// `Cluster::new` checks it first. The error names the field, the value and the rule.
    pub fn check(&self) -> Result<(), ConfigError> {
        check(self)
    }
}

/// Every rule, in the order of the fields.
fn check(c: &ClusterConfig) -> Result<(), ConfigError> {
    if c.cluster_id == ClusterId::SCENERY {
        return Err(refuse(
            "cluster_id",
            c.cluster_id,
            "the nil id stands for scenery (nobody's): give the cluster an id of its own",
        ));
    }
    neighbours(c)?;
    region("region", &c.region)?;
    if !(c.spread.is_finite() && c.spread >= 0.0) {
        return Err(refuse(
            "spread",
            c.spread,
            "must be a finite distance >= 0 m",
        ));
    }
    if !(c.dt.is_finite() && c.dt > 0.0 && c.dt <= 1.0) {
        return Err(refuse(
            "dt",
            c.dt,
            "must be a step of more than 0 and at most 1 s (a zero or negative step freezes every body)",
        ));
    }
    if c.replication_interval == 0 {
        return Err(refuse(
            "replication_interval",
            c.replication_interval,
            "must be 1 or more ticks (0 would never replicate)",
        ));
    }
    if !(c.max_linear_velocity.is_finite() && c.max_linear_velocity > 0.0) {
        return Err(refuse(
            "max_linear_velocity",
            c.max_linear_velocity,
            "must be a finite speed > 0 m/s",
        ));
    }
    if !c.gravity.iter().all(|g| g.is_finite()) {
        return Err(refuse(
            "gravity",
            c.gravity,
            "every component must be finite",
        ));
    }
    if c.transport.trim().is_empty() {
        return Err(refuse(
            "transport",
            &c.transport,
            "must name a transport: shm, local or redis://host:port",
        ));
    }
    ticks(c)?;
    if !(c.max_magnitude.is_finite() && c.max_magnitude > 0.0) {
        return Err(refuse(
            "max_magnitude",
            c.max_magnitude,
            "must be a finite bound > 0 (a negative one refuses everything, NaN nothing)",
        ));
    }
    world(c)?;
    names(c)?;
    if !(c.neighbour_wait_ticks.is_finite() && c.neighbour_wait_ticks >= 0.0) {
        return Err(refuse(
            "neighbour_wait_ticks",
            c.neighbour_wait_ticks,
            "must be a finite number of ticks >= 0",
        ));
    }
    Ok(())
}

/// The routed ops' tick counts.
fn ticks(c: &ClusterConfig) -> Result<(), ConfigError> {
    if c.op_retry_ticks == 0 {
        return Err(refuse(
            "op_retry_ticks",
            c.op_retry_ticks,
            "must be 1 or more ticks (0 would resend every op every tick forever)",
        ));
    }
    if c.max_op_age_ticks == 0 {
        return Err(refuse(
            "max_op_age_ticks",
            c.max_op_age_ticks,
            "must be 1 or more ticks (0 would drop every routed op as too old)",
        ));
    }
    Ok(())
}

fn neighbours(c: &ClusterConfig) -> Result<(), ConfigError> {
    for (i, &n) in c.neighbours.iter().enumerate() {
        if n == c.cluster_id {
            return Err(refuse(
                format!("neighbours[{i}]"),
                n,
                "a cluster is not its own neighbour",
            ));
        }
        if c.neighbours[..i].contains(&n) {
            return Err(refuse(format!("neighbours[{i}]"), n, "listed twice"));
        }
    }
    Ok(())
}

/// A region: no NaN, and on every axis `min <= max` (infinite bounds are fine: unbounded).
fn region(field: &str, r: &Region) -> Result<(), ConfigError> {
    if r.min.iter().chain(&r.max).any(|v| v.is_nan()) {
        return Err(refuse(field, r, "no bound may be NaN"));
    }
    if (0..3).any(|k| r.min[k] > r.max[k]) {
        return Err(refuse(field, r, "min must not exceed max on any axis"));
    }
    Ok(())
}

/// The world map, when there is one: each cluster once with a valid region, this one on it
/// with the region `region` says (given once: they must agree), and every neighbour on it.
fn world(c: &ClusterConfig) -> Result<(), ConfigError> {
    if c.world.is_empty() {
        return Ok(());
    }
    for (i, entry) in c.world.iter().enumerate() {
        region(&format!("world[{i}].region"), &entry.region)?;
        if !(entry.spread.is_finite() && entry.spread >= 0.0) {
            return Err(refuse(
                format!("world[{i}].spread"),
                entry.spread,
                "must be finite and >= 0 m (0: not known, the region alone)",
            ));
        }
        if c.world[..i].iter().any(|e| e.id == entry.id) {
            return Err(refuse(format!("world[{i}].id"), entry.id, "listed twice"));
        }
    }
    let Some(me) = c.world.iter().position(|e| e.id == c.cluster_id) else {
        return Err(refuse(
            "world",
            c.world.iter().map(|e| e.id).collect::<Vec<_>>(),
            "the world map must list this cluster (cluster_id)",
        ));
    };
    if c.region != Region::EVERYWHERE && c.world[me].region != c.region {
        return Err(refuse(
            format!("world[{me}].region"),
            c.world[me].region,
            "must be the cluster's `region` (one region per cluster: set it in one place, \
             or leave `region` as Region::EVERYWHERE)",
        ));
    }
    for (i, n) in c.neighbours.iter().enumerate() {
        if !c.world.iter().any(|e| e.id == *n) {
            return Err(refuse(
                format!("neighbours[{i}]"),
                n,
                "every neighbour must be on the world map",
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::WorldCluster;

    fn config() -> ClusterConfig {
        ClusterConfig::new(ClusterId::random(), vec![ClusterId::random()], "local")
    }

    /// The field the check names for `config`, if it refuses it.
    fn refused(change: impl FnOnce(&mut ClusterConfig)) -> Option<String> {
        let mut c = config();
        change(&mut c);
        check(&c).err().map(|e| {
            let text = e.to_string();
            assert!(text.contains(&e.field) && text.contains(e.rule), "{text}");
            e.field
        })
    }

    #[test]
    fn the_defaults_pass() {
        assert_eq!(check(&config()), Ok(()));
    }

    #[test]
    fn every_rule_names_its_field() {
        let field = |s: &str| Some(s.to_owned());
        assert_eq!(refused(|c| c.dt = 0.0), field("dt"));
        assert_eq!(refused(|c| c.dt = -1.0), field("dt"));
        assert_eq!(refused(|c| c.dt = f32::NAN), field("dt"));
        assert_eq!(
            refused(|c| c.gravity = [0.0, f32::NAN, 0.0]),
            field("gravity")
        );
        assert_eq!(
            refused(|c| c.replication_interval = 0),
            field("replication_interval")
        );
        assert_eq!(refused(|c| c.spread = -1.0), field("spread"));
        assert_eq!(refused(|c| c.spread = f32::NAN), field("spread"));
        assert_eq!(refused(|c| c.max_magnitude = -1.0), field("max_magnitude"));
        assert_eq!(
            refused(|c| c.max_linear_velocity = 0.0),
            field("max_linear_velocity")
        );
        assert_eq!(refused(|c| c.op_retry_ticks = 0), field("op_retry_ticks"));
        assert_eq!(
            refused(|c| c.max_op_age_ticks = 0),
            field("max_op_age_ticks")
        );
        assert_eq!(
            refused(|c| c.neighbour_wait_ticks = -0.5),
            field("neighbour_wait_ticks")
        );
        assert_eq!(refused(|c| c.transport = " ".into()), field("transport"));
        assert_eq!(
            refused(|c| c.cluster_id = ClusterId::SCENERY),
            field("cluster_id")
        );
        let inverted = Region {
            min: [1.0, 0.0, 0.0],
            max: [-1.0, 1.0, 1.0],
        };
        assert_eq!(refused(|c| c.region = inverted), field("region"));
        let nan = Region {
            min: [f32::NAN, 0.0, 0.0],
            max: [1.0; 3],
        };
        assert_eq!(refused(|c| c.region = nan), field("region"));
        assert_eq!(
            refused(|c| c.neighbours.push(c.cluster_id)),
            field("neighbours[1]")
        );
        assert_eq!(
            refused(|c| c.neighbours.push(c.neighbours[0])),
            field("neighbours[1]")
        );
    }

    #[test]
    fn clusters_are_named_where_named_and_names_are_printable() {
        let mut c = config();
        let (me, stranger) = (c.cluster_id, ClusterId::random());
        c.names.insert(me, "west".into());
        assert_eq!(c.label(me), format!("west ({me})"));
        assert_eq!(c.label(stranger), stranger.to_string());
        assert_eq!(check(&c), Ok(()));
        for bad in ["", " ", "a\nb"] {
            assert_eq!(
                refused(|c| {
                    c.names.insert(me, bad.into());
                })
                .map(|f| f.starts_with("names[")),
                Some(true),
                "{bad:?}"
            );
        }
        let (runner, stranger) = (EntityId::random(), EntityId::random());
        c.entity_names.insert(runner, "runner".into());
        assert_eq!(c.entity_label(runner), format!("runner ({runner})"));
        assert_eq!(c.entity_label(stranger), stranger.to_string());
        assert_eq!(check(&c), Ok(()));
        for bad in ["", "\t", &"x".repeat(65)] {
            assert_eq!(
                refused(|c| {
                    c.entity_names.insert(runner, bad.into());
                })
                .map(|f| f.starts_with("entity_names[")),
                Some(true),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn a_config_in_a_world_takes_its_region_spread_and_neighbours_from_it_once() {
        let (a, b, c) = (
            ClusterId::random(),
            ClusterId::random(),
            ClusterId::random(),
        );
        let slab = |x0: f32, x1: f32| Region {
            min: [x0, -10.0, -10.0],
            max: [x1, 10.0, 10.0],
        };
        // c is 5 m past b: within b's 3 m spread plus c's 2 m, out of a's reach.
        let world = [
            (a, slab(-10.0, 0.0), 1.0),
            (b, slab(0.0, 10.0), 3.0),
            (c, slab(15.0, 25.0), 2.0),
        ];
        let config = ClusterConfig::in_world(b, &world, "local").expect("on the map");
        assert_eq!((config.region, config.spread), (slab(0.0, 10.0), 3.0));
        assert_eq!(config.neighbours, vec![a, c]);
        assert_eq!(config.world.len(), 3);
        assert_eq!(check(&config), Ok(()));
        let stranger = ClusterConfig::in_world(ClusterId::random(), &world, "local");
        assert_eq!(
            stranger.map(|_| ()).map_err(|e| e.field),
            Err("world".to_owned())
        );
    }

    #[test]
    fn the_world_map_lists_this_cluster_with_its_region_and_its_neighbours() {
        let region = Region {
            min: [0.0; 3],
            max: [10.0; 3],
        };
        let map = |c: &ClusterConfig, region: Region| {
            let mut world = vec![WorldCluster {
                spread: 0.0,
                id: c.cluster_id,
                region,
                neighbours: c.neighbours.clone(),
            }];
            world.extend(c.neighbours.iter().map(|&n| WorldCluster {
                spread: 0.0,
                id: n,
                region: Region::EVERYWHERE,
                neighbours: vec![c.cluster_id],
            }));
            world
        };
        let ok = |c: &mut ClusterConfig| {
            c.region = region;
            c.world = map(c, region);
        };
        assert_eq!(refused(ok), None);
        assert_eq!(
            refused(|c| {
                c.world = map(c, region);
                c.world.remove(0);
            }),
            Some("world".to_owned())
        );
        assert_eq!(
            refused(|c| {
                c.region = region;
                c.world = map(c, region.grown(1.0));
            }),
            Some("world[0].region".to_owned())
        );
        assert_eq!(
            refused(|c| {
                c.world = map(c, region);
                c.world.pop();
            }),
            Some("neighbours[0]".to_owned())
        );
        assert_eq!(
            refused(|c| {
                c.world = map(c, region);
                let twice = c.world[1].clone();
                c.world.push(twice);
            }),
            Some("world[2].id".to_owned())
        );
        for bad in [-1.0, f32::NAN, f32::INFINITY] {
            assert_eq!(
                refused(|c| {
                    c.world = map(c, region);
                    c.world[1].spread = bad;
                }),
                Some("world[1].spread".to_owned()),
                "{bad}"
            );
        }
    }
}
