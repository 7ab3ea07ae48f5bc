//! A scene's world cut into another number of clusters ([`Scene::split_into`]), so one scene
//! can be measured on as many pods as a host has cores (`seam capacity`).

use super::model::{Cluster, Event, Region, Scene, Vec3};
use crate::error::{BenchError, BenchResult};

impl Scene {
    /// The scene on `pods` clusters: its own layout if it has that many, else the box its
    /// regions span cut into a grid of `pods` cells across x and z (as square as `pods`
    /// divides, more cells along the longer side), each a cluster named `part-I` with the
    /// largest spread of the scene's. An entity (every copy of a grid entry) goes to the cell
    /// its first copy starts in, and an event to the cell it happens in (the policy hands what
    /// starts elsewhere on at once). Refused for a scene with scripted hand-offs, which name a
    /// cluster the new layout does not have.
    pub fn split_into(&self, pods: usize) -> BenchResult<Scene> {
        if pods == self.clusters.len() {
            return Ok(self.clone());
        }
        if pods == 0 {
            return Err(BenchError::flag(
                "--rows",
                "a seam row needs at least one pod",
            ));
        }
        if self
            .events
            .iter()
            .any(|e| matches!(e, Event::Handoff { .. }))
        {
            return Err(BenchError::flag(
                "--rows",
                format!(
                    "scene {:?} hands entities to named clusters, which {pods} pods would not \
                     have: run it on its own {} clusters",
                    self.name,
                    self.clusters.len()
                ),
            ));
        }
        let cells = Cells::new(self.bounds(), pods);
        let mut scene = self.clone();
        scene.clusters = (0..pods)
            .map(|i| Cluster {
                name: cell_name(i),
                region: cells.region(i),
                spread: self.clusters.iter().map(|c| c.spread).fold(0.0, f32::max),
                host: None,
            })
            .collect();
        for entity in &mut scene.entities {
            if entity.owner.is_some() {
                entity.owner = Some(cell_name(cells.of(entity.position)));
            }
        }
        for event in &mut scene.events {
            match event {
                Event::Projectile {
                    by, position: at, ..
                }
                | Event::Explosion { by, center: at, .. }
                | Event::RaycastVolley { by, origin: at, .. } => *by = cell_name(cells.of(*at)),
                Event::Handoff { .. } | Event::Steer { .. } => {}
            }
        }
        Ok(scene)
    }

    /// The box every cluster's region lies in.
    fn bounds(&self) -> Region {
        let mut bounds = Region {
            min: [f32::INFINITY; 3],
            max: [f32::NEG_INFINITY; 3],
        };
        for cluster in &self.clusters {
            for a in 0..3 {
                bounds.min[a] = bounds.min[a].min(cluster.region.min[a]);
                bounds.max[a] = bounds.max[a].max(cluster.region.max[a]);
            }
        }
        bounds
    }
}

fn cell_name(index: usize) -> String {
    format!("part-{index}")
}

/// A box cut into `along_x` × `along_z` cells, numbered x first.
struct Cells {
    bounds: Region,
    along_x: usize,
    along_z: usize,
}

impl Cells {
    fn new(bounds: Region, pods: usize) -> Self {
        // The most square factoring of `pods`, its larger factor along the longer side.
        let small = (1..=pods)
            .take_while(|f| f * f <= pods)
            .filter(|f| pods.is_multiple_of(*f))
            .last()
            .unwrap_or(1);
        let large = pods / small;
        let x_longer = bounds.max[0] - bounds.min[0] >= bounds.max[2] - bounds.min[2];
        let (along_x, along_z) = if x_longer {
            (large, small)
        } else {
            (small, large)
        };
        Self {
            bounds,
            along_x,
            along_z,
        }
    }

    fn edge(&self, axis: usize, count: usize, i: usize) -> f32 {
        let (lo, hi) = (self.bounds.min[axis], self.bounds.max[axis]);
        lo + (hi - lo) * i as f32 / count as f32
    }

    /// Cell `index`'s region.
    fn region(&self, index: usize) -> Region {
        let (ix, iz) = (index % self.along_x, index / self.along_x);
        Region {
            min: [
                self.edge(0, self.along_x, ix),
                self.bounds.min[1],
                self.edge(2, self.along_z, iz),
            ],
            max: [
                self.edge(0, self.along_x, ix + 1),
                self.bounds.max[1],
                self.edge(2, self.along_z, iz + 1),
            ],
        }
    }

    /// The cell `at` is in (the nearest, outside the box).
    fn of(&self, at: Vec3) -> usize {
        let index = |axis: usize, count: usize| {
            let (lo, hi) = (self.bounds.min[axis], self.bounds.max[axis]);
            let t = ((at[axis] - lo) / (hi - lo)).clamp(0.0, 1.0);
            ((t * count as f32) as usize).min(count - 1)
        };
        index(0, self.along_x) + self.along_x * index(2, self.along_z)
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    /// A split scene written out (as `seam run --pods` and `seam capacity` hand it to their
    /// pods) reads back as the same scene.
    #[test]
    fn a_split_scene_saves_and_loads_back() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/grid.toml");
        let halves = crate::scene::load(&path)
            .expect("grid")
            .split_into(2)
            .expect("two pods");
        let out = std::env::temp_dir().join(format!("seam-split-{}.toml", std::process::id()));
        crate::scene::save(&halves, &out).expect("written");
        let back = crate::scene::load(&out);
        let _ = std::fs::remove_file(&out);
        assert_eq!(back.expect("reads back"), halves);
    }

    /// `grid`'s four quadrants cut in two: halves at x = 0, each field in the half it starts
    /// in; cut in four: the scene's own.
    #[test]
    fn grid_in_halves() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/grid.toml");
        let scene = crate::scene::load(&path).expect("grid");
        let halves = scene.split_into(2).expect("two pods");
        assert_eq!(halves.clusters.len(), 2);
        assert_eq!(halves.clusters[0].region.max[0], 0.0);
        assert_eq!(halves.clusters[1].region.min[0], 0.0);
        assert_eq!(halves.clusters[0].region.min[2], -60.0);
        assert_eq!(halves.clusters[0].region.max[2], 60.0);
        for entity in &halves.entities {
            let west = entity.position[0] < 0.0;
            let owner = entity.owner.as_deref().expect("owned");
            assert_eq!(
                owner,
                if west { "part-0" } else { "part-1" },
                "{}",
                entity.name
            );
        }
        assert_eq!(scene.split_into(4).expect("four pods"), scene);
        let six = scene.split_into(6).expect("six pods");
        let names: std::collections::BTreeSet<_> = six
            .entities
            .iter()
            .filter_map(|e| e.owner.clone())
            .collect();
        assert_eq!(names.len(), 4, "each field in its own cell: {names:?}");
    }

    /// A scene whose events hand entities to named clusters is not split.
    #[test]
    fn scripted_handoffs_are_not_split() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/variants/crossfire-handoff.toml");
        let scene = crate::scene::load(&path).expect("crossfire-handoff");
        let error = scene.split_into(3).expect_err("refused");
        assert!(error.to_string().contains("named clusters"), "{error}");
    }
}
