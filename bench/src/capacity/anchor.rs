//! The plain-Rapier rows of `seam capacity`: the scene as a `seam_anchor::WorldSpec`, the
//! `seam-anchor` binary built with the Rapier features a row asks for, and one run of it.
//!
//! Each build is of the anchor crate alone (`cargo build -p seam-anchor --features ...`) into
//! its own corner of the target folder, so a row's features (Rapier's `parallel`,
//! `enhanced-determinism`) are exactly the ones it names, whatever the rest of the workspace
//! turns on; built once, reused after (cargo rebuilds only what changed).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use seam_anchor::{BodySpec, Motion, ShapeSpec, Timings, WorldSpec};

use crate::error::{BenchError, BenchResult};
use crate::scene::{Role, Scene, SceneShape};

/// A build of the anchor: which of Rapier's features it has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Build {
    /// Rapier's `parallel`: steps on every core through rayon.
    pub parallel: bool,
    /// Rapier's `enhanced-determinism` (seam's own worlds have it).
    pub determinism: bool,
}

impl Build {
    fn features(self) -> String {
        let mut features = Vec::new();
        if self.parallel {
            features.push("parallel");
        }
        if self.determinism {
            features.push("determinism");
        }
        features.join(",")
    }

    fn file_name(self) -> String {
        match self.features() {
            f if f.is_empty() => "seam-anchor-plain".to_owned(),
            f => format!("seam-anchor-{}", f.replace(',', "-")),
        }
    }
}

/// The scene's bodies as one plain world: every copy of every entity, scenery as fixed
/// bodies, masses as densities the way pods set them. Refused for shapes the anchor does not
/// model (hulls, compounds, meshes, heightfields).
pub(super) fn world_of(scene: &Scene) -> BenchResult<WorldSpec> {
    let mut bodies = Vec::new();
    for entity in &scene.entities {
        let shape = match entity.shape {
            SceneShape::Ball { radius } => ShapeSpec::Ball { radius },
            SceneShape::Cuboid { half_extents } => ShapeSpec::Cuboid { half_extents },
            SceneShape::Capsule {
                half_height,
                radius,
            } => ShapeSpec::Capsule {
                half_height,
                radius,
            },
            _ => {
                return Err(BenchError::flag(
                    "SCENE",
                    format!(
                        "entity {:?}: the plain-Rapier anchor models balls, cuboids and \
                         capsules only",
                        entity.name
                    ),
                ));
            }
        };
        let volume = entity.shape.volume();
        let motion = match entity.role {
            Role::Dynamic => Motion::Dynamic,
            Role::Kinematic => Motion::Kinematic,
            Role::Fixed | Role::Scenery => Motion::Fixed,
        };
        for position in entity.positions() {
            bodies.push(BodySpec {
                shape,
                motion,
                density: if volume > 0.0 {
                    entity.mass() / volume
                } else {
                    1.0
                },
                position,
                rotation: entity.rotation,
                linvel: entity.velocity,
                angvel: entity.angvel,
                friction: entity.friction,
                restitution: entity.restitution,
                damping: [entity.linear_damping, entity.angular_damping],
                ccd: entity.ccd,
            });
        }
    }
    Ok(WorldSpec {
        gravity: scene.gravity,
        dt: scene.dt,
        max_speed: scene.max_speed,
        bodies,
    })
}

/// The workspace this executable was built from.
fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// Builds the anchor with `build`'s features (quietly; cargo does nothing when it is up to
/// date) and returns the binary.
pub(super) fn binary(build: Build) -> BenchResult<PathBuf> {
    let root = workspace();
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map_or_else(|| root.join("target"), PathBuf::from)
        .join("anchors");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut command = Command::new(&cargo);
    command
        .args([
            "build",
            "--release",
            "--quiet",
            "-p",
            "seam-anchor",
            "--manifest-path",
        ])
        .arg(root.join("Cargo.toml"))
        .arg("--target-dir")
        .arg(&target);
    if !build.features().is_empty() {
        command.args(["--features", &build.features()]);
    }
    let status = command
        .status()
        .map_err(|e| BenchError::io("run", format!("{cargo:?} (to build the anchor)"), e))?;
    if !status.success() {
        return Err(BenchError::process(
            "cargo build -p seam-anchor",
            format!("{status}: the plain-Rapier anchor did not build (its error is above)"),
        ));
    }
    let bin_dir = target.join("bin");
    std::fs::create_dir_all(&bin_dir)
        .map_err(|e| BenchError::io("create", bin_dir.display(), e))?;
    let built = target.join("release").join("seam-anchor");
    let kept = bin_dir.join(build.file_name());
    // Copied beside, then renamed over: a copy of it may still be running.
    let fresh = bin_dir.join(format!("{}.{}", build.file_name(), std::process::id()));
    std::fs::copy(&built, &fresh).map_err(|e| BenchError::io("copy", built.display(), e))?;
    std::fs::rename(&fresh, &kept).map_err(|e| BenchError::io("rename", fresh.display(), e))?;
    Ok(kept)
}

/// The scene cut into `parts` as seam's rows cut it (`Scene::split_into`), each part's owned
/// bodies and all the scenery as a world of its own.
pub(super) fn worlds_apart(scene: &Scene, parts: usize) -> BenchResult<Vec<WorldSpec>> {
    let split = scene.split_into(parts)?;
    split
        .clusters
        .iter()
        .map(|cluster| {
            let mut part = split.clone();
            part.entities
                .retain(|e| e.owner.as_ref().is_none_or(|owner| *owner == cluster.name));
            world_of(&part)
        })
        .collect()
}

/// Runs `binary` on each of `worlds` (written to `scratch`) for `ticks` at `rate`, every world
/// in a process of its own, all at once; each world's timings, in order.
pub(super) fn run_side_by_side(
    binary: &Path,
    worlds: &[WorldSpec],
    scratch: &Path,
    ticks: u64,
    rate: f64,
) -> BenchResult<Vec<Timings>> {
    let mut children = Vec::new();
    for (i, world) in worlds.iter().enumerate() {
        let path = scratch.join(format!("world-{i}.json"));
        let json = serde_json::to_vec(world)?;
        std::fs::write(&path, json).map_err(|e| BenchError::io("write", path.display(), e))?;
        let child = Command::new(binary)
            .arg(&path)
            .arg(ticks.to_string())
            .arg(rate.to_string())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| BenchError::io("run", binary.display(), e))?;
        children.push(child);
    }
    // Every child is waited for, even after one failed, so none is left running.
    let outputs: Vec<_> = children
        .into_iter()
        .map(std::process::Child::wait_with_output)
        .collect();
    outputs
        .into_iter()
        .map(|output| {
            let output = output.map_err(|e| BenchError::io("wait for", binary.display(), e))?;
            if !output.status.success() {
                return Err(BenchError::process(
                    binary.display(),
                    format!(
                        "{}: {}",
                        output.status,
                        String::from_utf8_lossy(&output.stderr).trim()
                    ),
                ));
            }
            Ok(serde_json::from_slice(&output.stdout)?)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use seam_anchor::Motion;

    /// `grid` in two worlds apart: the western fields in one, the eastern in the other, every
    /// ball once; a part's scenery would be in every world.
    #[test]
    fn grid_apart_in_halves() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/grid.toml");
        let scene = crate::scene::load(&path).expect("grid");
        let worlds = super::worlds_apart(&scene, 2).expect("two worlds");
        assert_eq!(worlds.len(), 2);
        for (world, west) in worlds.iter().zip([true, false]) {
            assert_eq!(world.bodies.len(), 1_250);
            assert!(
                world
                    .bodies
                    .iter()
                    .all(|b| (b.position[0] < 0.0) == west && b.motion == Motion::Dynamic)
            );
        }
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/capacity/piles.toml");
        let piles = crate::scene::load(&path).expect("piles");
        let fixed = |w: &seam_anchor::WorldSpec| {
            w.bodies
                .iter()
                .filter(|b| b.motion == Motion::Fixed)
                .count()
        };
        let whole = super::world_of(&piles).expect("one world");
        let apart = super::worlds_apart(&piles, 2).expect("two worlds");
        assert!(fixed(&whole) > 0);
        assert!(apart.iter().all(|w| fixed(w) == fixed(&whole)));
        let moving = |w: &seam_anchor::WorldSpec| w.bodies.len() - fixed(w);
        assert_eq!(apart.iter().map(moving).sum::<usize>(), moving(&whole));
    }
}
