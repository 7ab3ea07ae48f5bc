//! Scene shapes: primitives, and the shapes every cluster registers in its catalog.

use serde::{Deserialize, Serialize};

use seam_sim::wire::Shape;
use seam_sim::{Part, ShapeCatalog, ShapeDef};

use super::Vec3;
use super::model::identity;

/// A collision shape: a primitive, or one every cluster registers in its shape catalog
/// (`convex_hull`, `compound`, `trimesh`, `heightfield`) and that travels by content hash.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SceneShape {
    /// A sphere.
    Ball {
        /// Radius, m.
        radius: f32,
    },
    /// A box.
    Cuboid {
        /// Half sizes, m.
        half_extents: Vec3,
    },
    /// A capsule along y.
    Capsule {
        /// Half the straight part, m.
        half_height: f32,
        /// Radius, m.
        radius: f32,
    },
    /// The convex hull of `points` (body frame), for dynamic bodies too.
    ConvexHull {
        /// At least 4 points not in one plane, m.
        points: Vec<Vec3>,
    },
    /// Balls, cuboids and capsules fixed together, for dynamic bodies too.
    Compound {
        /// The parts.
        parts: Vec<ScenePart>,
    },
    /// A triangle mesh: scenery, fixed and kinematic bodies only.
    Trimesh {
        /// Vertices (body frame), m.
        vertices: Vec<Vec3>,
        /// Triangles, three vertex indices each.
        triangles: Vec<[u32; 3]>,
    },
    /// Terrain on the x-z plane centred on the body origin: scenery, fixed and kinematic
    /// bodies only.
    Heightfield {
        /// Heights, one list per row; rows run along x, from -z to +z (at least 2 x 2).
        heights: Vec<Vec<f32>>,
        /// Extent along x, height scale, extent along z, m.
        size: Vec3,
    },
}

/// One part of a compound shape.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ScenePart {
    /// Its shape: a ball, cuboid or capsule.
    pub shape: SceneShape,
    /// Where its origin is in the body frame, m.
    #[serde(default)]
    pub position: Vec3,
    /// Its orientation `[x, y, z, w]`; identity if left out.
    #[serde(default = "identity")]
    pub rotation: [f32; 4],
}

impl SceneShape {
    /// Volume in m³ (0 for a triangle mesh or a heightfield, or a shape Rapier cannot build).
    pub fn volume(&self) -> f32 {
        use std::f32::consts::PI;
        match self {
            SceneShape::Ball { radius } => 4.0 / 3.0 * PI * radius.powi(3),
            SceneShape::Cuboid {
                half_extents: [x, y, z],
            } => 8.0 * x * y * z,
            SceneShape::Capsule {
                half_height,
                radius,
            } => PI * radius * radius * (2.0 * half_height + 4.0 / 3.0 * radius),
            _ => {
                let mut catalog = ShapeCatalog::default();
                self.catalog_def()
                    .and_then(|def| {
                        let id = def.id();
                        catalog.add(def).ok()?;
                        catalog.volume(id)
                    })
                    .unwrap_or(0.0)
            }
        }
    }

    /// The wire shape of a primitive (`None` for a catalog shape).
    pub fn primitive(&self) -> Option<Shape> {
        Some(match *self {
            SceneShape::Ball { radius } => Shape::Ball { radius },
            SceneShape::Cuboid { half_extents } => Shape::Cuboid { half_extents },
            SceneShape::Capsule {
                half_height,
                radius,
            } => Shape::Capsule {
                half_height,
                radius,
            },
            _ => return None,
        })
    }

    /// The catalog definition of a catalog shape (`None` for a primitive, or a compound with
    /// a part that is not a primitive). Heightfield rows of unequal length give no heights,
    /// which the catalog refuses.
    pub fn catalog_def(&self) -> Option<ShapeDef> {
        Some(match self {
            SceneShape::ConvexHull { points } => ShapeDef::ConvexHull {
                points: points.clone(),
            },
            SceneShape::Compound { parts } => ShapeDef::Compound {
                parts: parts
                    .iter()
                    .map(|p| {
                        Some(Part {
                            position: p.position,
                            rotation: p.rotation,
                            shape: p.shape.primitive()?,
                        })
                    })
                    .collect::<Option<_>>()?,
            },
            SceneShape::Trimesh {
                vertices,
                triangles,
            } => ShapeDef::TriMesh {
                vertices: vertices.clone(),
                triangles: triangles.clone(),
            },
            SceneShape::Heightfield { heights, size } => {
                let columns = heights.first().map_or(0, Vec::len);
                let even = heights.iter().all(|r| r.len() == columns);
                ShapeDef::HeightField {
                    rows: heights.len() as u32,
                    columns: columns as u32,
                    heights: if even { heights.concat() } else { Vec::new() },
                    size: *size,
                }
            }
            _ => return None,
        })
    }

    /// Whether a dynamic body may have it (it has a volume).
    pub fn has_volume(&self) -> bool {
        !matches!(
            self,
            SceneShape::Trimesh { .. } | SceneShape::Heightfield { .. }
        )
    }

    /// Why a body cannot have it, if it cannot.
    pub(super) fn problem(&self) -> Option<String> {
        if let Some(shape) = self.primitive() {
            return (!seam_sim::shapes::primitive_ok(&shape))
                .then(|| "sizes must be positive".to_owned());
        }
        let Some(def) = self.catalog_def() else {
            return Some("a compound's parts are balls, cuboids and capsules".into());
        };
        ShapeCatalog::default().add(def).err().map(|e| match e {
            seam_sim::SimError::BadCatalogShape { reason, .. } => reason.to_owned(),
            other => other.to_string(),
        })
    }

    /// Half its extent along x and z, for drawing it from above (`None`: draw it round, of
    /// its radius).
    pub fn footprint(&self) -> Option<[f32; 2]> {
        let farthest = |points: &[Vec3]| {
            points.iter().fold([0.0f32; 2], |[x, z], p| {
                [x.max(p[0].abs()), z.max(p[2].abs())]
            })
        };
        match self {
            SceneShape::Ball { .. } | SceneShape::Capsule { .. } => None,
            SceneShape::Cuboid { half_extents } => Some([half_extents[0], half_extents[2]]),
            SceneShape::ConvexHull { points } => Some(farthest(points)),
            SceneShape::Trimesh { vertices, .. } => Some(farthest(vertices)),
            SceneShape::Heightfield { size, .. } => Some([size[0] / 2.0, size[2] / 2.0]),
            SceneShape::Compound { parts } => Some(parts.iter().fold([0.0f32; 2], |[x, z], p| {
                let [px, pz] = p.shape.footprint().unwrap_or([p.shape.radius(); 2]);
                [
                    x.max(p.position[0].abs() + px),
                    z.max(p.position[2].abs() + pz),
                ]
            })),
        }
    }

    /// The radius of a ball or capsule (0 for other shapes).
    pub fn radius(&self) -> f32 {
        match *self {
            SceneShape::Ball { radius } | SceneShape::Capsule { radius, .. } => radius,
            _ => 0.0,
        }
    }
}
