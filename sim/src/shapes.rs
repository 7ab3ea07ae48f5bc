//! [`ShapeCatalog`]: the shapes too large to travel with every state (convex hulls, compound
//! shapes, triangle meshes, heightfields), registered by every cluster of a world and named on
//! the wire by their content hash ([`ShapeId`]).
//!
//! A world's clusters each register the same definitions (from the same scene or game data):
//! equal definitions hash to equal ids, so a state naming a shape means the same points
//! everywhere, and a state naming a shape a cluster never registered is refused there
//! ([`SimError::UnknownShape`]) rather than simulated as something else.

use std::collections::HashMap;

use rapier3d::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::SimError;
use crate::wire::{Shape, ShapeId};

/// A shape of the catalog, as game data gives it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ShapeDef {
    /// The convex hull of `points` (body frame, metres): rocks, debris, crates with bevels.
    ConvexHull {
        /// At least four points not all in one plane.
        points: Vec<[f32; 3]>,
    },
    /// Primitives fixed together in one body: a table, a dumbbell, an L-shaped beam.
    Compound {
        /// The parts, each a ball, cuboid or capsule at a pose in the body frame.
        parts: Vec<Part>,
    },
    /// A triangle mesh (scenery and bodies moved by their owner only: it has no volume).
    TriMesh {
        /// Vertices, body frame, metres.
        vertices: Vec<[f32; 3]>,
        /// Triangles, three vertex indices each.
        triangles: Vec<[u32; 3]>,
    },
    /// A heightfield on the x-z plane centred on the body origin: terrain (scenery and bodies
    /// moved by their owner only).
    HeightField {
        /// Heights, row after row: row `r` runs along x at z = -size_z/2 + r·size_z/(rows-1);
        /// `rows × columns` of them, each scaled by `size[1]`.
        heights: Vec<f32>,
        /// Rows (along z), at least 2.
        rows: u32,
        /// Columns (along x), at least 2.
        columns: u32,
        /// Extent along x, height scale, extent along z, metres.
        size: [f32; 3],
    },
}

/// One part of a [`ShapeDef::Compound`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Part {
    /// Where its origin is in the body frame, metres.
    pub position: [f32; 3],
    /// Its orientation, a unit quaternion `[x, y, z, w]`.
    pub rotation: [f32; 4],
    /// A ball, cuboid or capsule.
    pub shape: Shape,
}

impl ShapeDef {
    /// Its content hash: the first 8 bytes of the BLAKE3 hash of its postcard encoding.
    pub fn id(&self) -> ShapeId {
        let bytes = postcard::to_allocvec(self).unwrap_or_default();
        let hash = blake3::hash(&bytes);
        let mut first = [0u8; 8];
        first.copy_from_slice(&hash.as_bytes()[..8]);
        ShapeId(u64::from_le_bytes(first))
    }

    /// Whether a simulated (dynamic) body may have it: one with a volume.
    pub fn has_volume(&self) -> bool {
        matches!(
            self,
            ShapeDef::ConvexHull { .. } | ShapeDef::Compound { .. }
        )
    }

    /// Rapier's shape, or why it cannot be one.
    fn build(&self) -> Result<SharedShape, &'static str> {
        let finite = |p: &[f32; 3]| p.iter().all(|v| v.is_finite());
        match self {
            ShapeDef::ConvexHull { points } => {
                if points.len() < 4 || !points.iter().all(finite) {
                    return Err("a convex hull needs at least 4 finite points");
                }
                let points: Vec<Vector> = points.iter().map(|&p| Vector::from_array(p)).collect();
                SharedShape::convex_hull(&points)
                    .filter(|hull| hull.mass_properties(1.0).mass() > 1e-9)
                    .ok_or("the points span no volume")
            }
            ShapeDef::Compound { parts } => {
                if parts.is_empty() {
                    return Err("a compound shape needs at least one part");
                }
                let mut built = Vec::with_capacity(parts.len());
                for part in parts {
                    built.push(part.build()?);
                }
                Ok(SharedShape::compound(built))
            }
            ShapeDef::TriMesh {
                vertices,
                triangles,
            } => {
                let count = vertices.len();
                if triangles.is_empty()
                    || !vertices.iter().all(finite)
                    || triangles.iter().flatten().any(|&i| i as usize >= count)
                {
                    return Err(
                        "a triangle mesh needs finite vertices and triangles indexing them",
                    );
                }
                let vertices = vertices.iter().map(|&p| Vector::from_array(p)).collect();
                SharedShape::trimesh(vertices, triangles.clone())
                    .map_err(|_| "the triangles make no mesh")
            }
            ShapeDef::HeightField {
                heights,
                rows,
                columns,
                size,
            } => {
                let (rows, columns) = (*rows as usize, *columns as usize);
                if rows < 2
                    || columns < 2
                    || rows.checked_mul(columns) != Some(heights.len())
                    || !heights.iter().all(|h| h.is_finite())
                    || !size.iter().all(|s| s.is_finite() && *s > 0.0)
                {
                    return Err(
                        "a heightfield needs rows, columns >= 2, rows x columns finite heights \
                         and a positive size",
                    );
                }
                // Parry's grid is column-major with rows along z: (r, c) at r + c * rows.
                let mut column_major = vec![0.0; heights.len()];
                for r in 0..rows {
                    for c in 0..columns {
                        column_major[r + c * rows] = heights[r * columns + c];
                    }
                }
                let grid = rapier3d::parry::utils::Array2::new(rows, columns, column_major);
                Ok(SharedShape::heightfield(grid, Vector::from_array(*size)))
            }
        }
    }
}

impl Part {
    fn build(&self) -> Result<(Pose, SharedShape), &'static str> {
        let pose_ok = self.position.iter().all(|v| v.is_finite()) && {
            let [x, y, z, w] = self.rotation;
            ((x * x + y * y + z * z + w * w).sqrt() - 1.0).abs() <= 1e-3
        };
        if !pose_ok {
            return Err("a part's position must be finite and its rotation a unit quaternion");
        }
        if !primitive_ok(&self.shape) {
            return Err("a part is a ball, cuboid or capsule of positive finite sizes");
        }
        let shape = primitive(&self.shape).ok_or("a part cannot be a catalog shape")?;
        let [x, y, z, w] = self.rotation;
        let pose = Pose::from_parts(
            Vector::from_array(self.position),
            Rotation::from_xyzw(x, y, z, w).normalize(),
        );
        Ok((pose, shape))
    }
}

fn positive(x: f32) -> bool {
    x.is_finite() && x > 0.0
}

/// Whether a primitive's sizes are positive and finite (a catalog shape is not a primitive).
pub fn primitive_ok(shape: &Shape) -> bool {
    match *shape {
        Shape::Ball { radius } => positive(radius),
        Shape::Cuboid { half_extents } => half_extents.iter().all(|&h| positive(h)),
        Shape::Capsule {
            half_height,
            radius,
        } => positive(radius) && half_height.is_finite() && half_height >= 0.0,
        Shape::Catalog { .. } => false,
    }
}

/// Rapier's shape for a primitive (`None` for a catalog shape).
pub(crate) fn primitive(shape: &Shape) -> Option<SharedShape> {
    Some(match *shape {
        Shape::Ball { radius } => SharedShape::ball(radius),
        Shape::Cuboid {
            half_extents: [x, y, z],
        } => SharedShape::cuboid(x, y, z),
        Shape::Capsule {
            half_height,
            radius,
        } => SharedShape::capsule_y(half_height, radius),
        Shape::Catalog { .. } => return None,
    })
}

/// One registered shape.
#[derive(Clone)]
struct Registered {
    def: ShapeDef,
    shape: SharedShape,
    /// Volume, m³ (0 for meshes and heightfields).
    volume: f32,
}

/// The shapes a world's clusters register, by content hash. Rapier shares each one's geometry
/// between every body that has it.
#[derive(Clone, Default)]
pub struct ShapeCatalog {
    shapes: HashMap<ShapeId, Registered>,
}

impl std::fmt::Debug for ShapeCatalog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_set().entries(self.shapes.keys()).finish()
    }
}

impl ShapeCatalog {
    /// Registers `def` (again, harmlessly, if it is there) and returns the [`Shape`] that names
    /// it, with its bound; or why Rapier cannot build it ([`SimError::BadCatalogShape`]).
    pub fn add(&mut self, def: ShapeDef) -> Result<Shape, SimError> {
        let id = def.id();
        if let std::collections::hash_map::Entry::Vacant(slot) = self.shapes.entry(id) {
            let shape = def
                .build()
                .map_err(|reason| SimError::BadCatalogShape { id, reason })?;
            let volume = if def.has_volume() {
                shape.mass_properties(1.0).mass()
            } else {
                0.0
            };
            slot.insert(Registered { def, shape, volume });
        }
        self.shape(id).ok_or(SimError::UnknownShape(id))
    }

    /// The [`Shape`] naming registered shape `id`, with its bound.
    pub fn shape(&self, id: ShapeId) -> Option<Shape> {
        let sphere = self.shapes.get(&id)?.shape.compute_local_bounding_sphere();
        let bound = sphere.center.length() + sphere.radius;
        Some(Shape::Catalog { id, bound })
    }

    /// The definition of `id`.
    pub fn def(&self, id: ShapeId) -> Option<&ShapeDef> {
        self.shapes.get(&id).map(|r| &r.def)
    }

    /// The volume of `id`, m³ (mass = density × volume); 0 for a mesh or a heightfield.
    pub fn volume(&self, id: ShapeId) -> Option<f32> {
        self.shapes.get(&id).map(|r| r.volume)
    }

    /// How many shapes it holds.
    pub fn len(&self) -> usize {
        self.shapes.len()
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// Rapier's shape for `shape`: a primitive's own, or the registered one a catalog shape
    /// names (or its id, if it is not registered here).
    pub(crate) fn resolve(&self, shape: &Shape) -> Result<SharedShape, ShapeId> {
        match *shape {
            Shape::Catalog { id, .. } => self.shapes.get(&id).map(|r| r.shape.clone()).ok_or(id),
            _ => primitive(shape).ok_or(ShapeId(0)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra(scale: f32) -> ShapeDef {
        ShapeDef::ConvexHull {
            points: vec![
                [0.0, 0.0, 0.0],
                [scale, 0.0, 0.0],
                [0.0, scale, 0.0],
                [0.0, 0.0, scale],
            ],
        }
    }

    #[test]
    fn equal_definitions_share_an_id_and_different_ones_do_not() {
        assert_eq!(tetra(1.0).id(), tetra(1.0).id());
        assert_ne!(tetra(1.0).id(), tetra(2.0).id());
        let mut catalog = ShapeCatalog::default();
        let a = catalog.add(tetra(1.0)).expect("a hull");
        let b = catalog.add(tetra(1.0)).expect("again");
        assert_eq!(a, b);
        assert_eq!(catalog.len(), 1);
        let volume = catalog.volume(tetra(1.0).id()).expect("registered");
        assert!((volume - 1.0 / 6.0).abs() < 1e-4, "{volume}");
    }

    #[test]
    fn shapes_rapier_cannot_build_are_refused_with_why() {
        let mut catalog = ShapeCatalog::default();
        let flat = ShapeDef::ConvexHull {
            points: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0]],
        };
        let bad = [
            flat,
            ShapeDef::ConvexHull {
                points: vec![[f32::NAN; 3]; 4],
            },
            ShapeDef::Compound { parts: vec![] },
            ShapeDef::TriMesh {
                vertices: vec![[0.0; 3]; 3],
                triangles: vec![[0, 1, 3]],
            },
            ShapeDef::HeightField {
                heights: vec![0.0; 3],
                rows: 2,
                columns: 2,
                size: [1.0; 3],
            },
        ];
        for def in bad {
            let error = catalog.add(def.clone()).expect_err("refused");
            assert!(
                matches!(error, SimError::BadCatalogShape { .. }),
                "{def:?}: {error}"
            );
        }
        assert!(catalog.is_empty());
    }

    #[test]
    fn a_compound_bound_holds_its_parts() {
        let mut catalog = ShapeCatalog::default();
        let dumbbell = ShapeDef::Compound {
            parts: vec![
                Part {
                    position: [-1.0, 0.0, 0.0],
                    rotation: [0.0, 0.0, 0.0, 1.0],
                    shape: Shape::ball(0.5),
                },
                Part {
                    position: [1.0, 0.0, 0.0],
                    rotation: [0.0, 0.0, 0.0, 1.0],
                    shape: Shape::ball(0.5),
                },
            ],
        };
        let Shape::Catalog { bound, .. } = catalog.add(dumbbell).expect("a compound") else {
            panic!("a catalog shape");
        };
        assert!(bound >= 1.5 - 1e-4, "{bound}");
    }
}
