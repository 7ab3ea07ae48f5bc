//! Scenes: what a run simulates, in a small TOML format (`bench/scenes/*.toml`).
//!
//! A scene names its clusters (each with the region it observes), its entities (shape, mass,
//! pose, velocity, owner, role, CCD; `grid` repeats one entity over a lattice), and scripted
//! events by tick: a projectile, an explosion (impulses on everything within a radius), a
//! raycast volley, a hand-off of authority. An entity walking across a region boundary is just
//! an entity with a velocity. A scene models what it needs and nothing more.
//!
//! Roles: `dynamic` (the default: simulated by its owner), `fixed` and `kinematic` (owned and
//! replicated, moved only by their owner), and `scenery`: static level geometry that every
//! cluster loads itself, owned by none and never replicated — it takes no `owner` and no
//! `mass`:
//!
//! ```toml
//! [[entity]]
//! name = "floor"
//! role = "scenery"
//! shape = { kind = "cuboid", half_extents = [30, 0.5, 10] }
//! position = [0, -0.5, 0]
//! ```
//!
//! ```toml
//! name = "example"
//! ticks = 600
//!
//! [[cluster]]
//! name = "west"
//! region = { min = [-50, -10, -50], max = [0, 50, 50] }
//! spread = 2.0
//!
//! [[entity]]
//! name = "crate"
//! owner = "west"
//! shape = { kind = "cuboid", half_extents = [0.5, 0.5, 0.5] }
//! mass = 20.0
//! position = [-5, 0.5, 0]
//!
//! [[event]]
//! tick = 60
//! kind = "explosion"
//! by = "west"
//! center = [-5, 0, 0]
//! radius = 4.0
//! impulse = 200.0
//! ```
//!
//! An entity may set its material (`friction`, 0.5 unless set; `restitution`;
//! `linear_damping`; `angular_damping`), its collision `groups` (`{ memberships = 1, filter =
//! 0xffffffff }`: two bodies meet when each one's memberships share a bit with the other's
//! filter) and `sensor = true` (it pushes nothing and reports what enters and leaves it).
//! Besides `ball`, `cuboid` and `capsule`, a shape may be a `convex_hull` (`points`), a
//! `compound` (`parts`, each a primitive `shape` at a `position` and `rotation`), a `trimesh`
//! (`vertices`, `triangles`) or a `heightfield` (`heights`, one list per row from -z to +z,
//! and `size` = [x extent, height scale, z extent]); every pod registers these in its shape
//! catalog and they travel by content hash. Meshes and heightfields have no volume: scenery,
//! fixed and kinematic bodies only (`bench/scenes/terrain.toml`, `hull-pile.toml`).
//!
//! Loading checks everything a run relies on (known clusters and entities, finite numbers,
//! positive sizes) and reports a bad file as `FILE:LINE:COLUMN: field \`NAME\`: what is wrong`.

mod model;
mod shape;
mod split;

pub use model::{Cluster, Entity, Event, Grid, Region, Role, Scene, SceneGroups, Vec3, host_name};
pub use shape::{ScenePart, SceneShape};

use std::path::Path;

/// Why a scene file cannot be used.
#[derive(Debug)]
pub struct SceneError {
    /// The file.
    pub file: String,
    /// 1-based line of the offending value (0 when the file could not be read).
    pub line: usize,
    /// 1-based column.
    pub column: usize,
    /// What is wrong, naming the field.
    pub message: String,
}

impl std::fmt::Display for SceneError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            // Not about a place in the file (it could not be read).
            write!(f, "{}: {}", self.file, self.message)
        } else {
            write!(
                f,
                "{}:{}:{}: {}",
                self.file, self.line, self.column, self.message
            )
        }
    }
}

impl std::error::Error for SceneError {}

/// Line and column (1-based) of byte `offset` in `text`.
fn position(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    (line, column)
}

/// The key written on the line holding byte `offset` (`key = value`), if any.
fn key_at(text: &str, offset: usize) -> Option<&str> {
    let offset = offset.min(text.len());
    let start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let line = &text[start..end];
    let key = line.split('=').next()?.trim();
    (line.contains('=') && !key.is_empty() && !key.starts_with('[')).then_some(key)
}

/// Reads and checks a scene file.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| SceneError {
        file: file.clone(),
        line: 0,
        column: 0,
        message: format!("cannot read: {e}"),
    })?;
    parse(&file, &text)
}

/// Writes `scene` to `path` as a scene file (a split one, for pods that read their scene from
/// a file).
pub fn save(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    let error = |message: String| SceneError {
        file: path.display().to_string(),
        line: 0,
        column: 0,
        message,
    };
    let text = toml::to_string(scene).map_err(|e| error(format!("cannot write it: {e}")))?;
    std::fs::write(path, text).map_err(|e| error(format!("cannot write: {e}")))
}

/// Parses and checks scene `text`; `file` names it in errors.
pub fn parse(file: &str, text: &str) -> Result<Scene, SceneError> {
    let error_at = |offset: usize, message: String| {
        let (line, column) = position(text, offset);
        SceneError {
            file: file.to_owned(),
            line,
            column,
            message,
        }
    };
    let scene: Scene = toml::from_str(text).map_err(|e| {
        let offset = e.span().map_or(0, |span| span.start);
        let message = e.message().trim().to_owned();
        match key_at(text, offset) {
            Some(key) if !message.contains(&format!("`{key}`")) => {
                error_at(offset, format!("field `{key}`: {message}"))
            }
            _ => error_at(offset, message),
        }
    })?;
    scene
        .check(text)
        .map_err(|(offset, message)| error_at(offset, message))?;
    Ok(scene)
}

#[cfg(test)]
mod tests;
