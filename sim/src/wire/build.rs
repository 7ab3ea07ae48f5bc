//! Builders for the wire types, so game code names what it sets and leaves the rest at rest:
//!
//! ```
//! use seam_sim::wire::{BodySpec, ClusterId, EntityId, EntityState, Shape};
//!
//! let west = ClusterId::named("match-42", "west");
//! let crate_ = EntityState::new(
//!     EntityId::named("match-42", "crate"),
//!     west,
//!     BodySpec::new(Shape::cuboid(0.5, 0.5, 0.5)).density(500.0),
//! )
//! .at([10.0, 0.5, 0.0])
//! .velocity([-2.0, 0.0, 0.0]);
//! assert_eq!(crate_.cluster_id, west);
//! assert_eq!(crate_.rotation, [0.0, 0.0, 0.0, 1.0]);
//! ```

use super::{BodySpec, ClusterId, EntityId, EntityState, Groups, Material, Motion, Shape};

impl Shape {
    /// A sphere of `radius` metres.
    pub fn ball(radius: f32) -> Self {
        Self::Ball { radius }
    }

    /// A box of half-sizes `hx`, `hy`, `hz` metres.
    pub fn cuboid(hx: f32, hy: f32, hz: f32) -> Self {
        Self::Cuboid {
            half_extents: [hx, hy, hz],
        }
    }

    /// A capsule along the local y axis: a straight part of half-length `half_height` and
    /// `radius`, metres.
    pub fn capsule(half_height: f32, radius: f32) -> Self {
        Self::Capsule {
            half_height,
            radius,
        }
    }
}

impl BodySpec {
    /// `shape` with density 1 000 kg/m³ (water), no CCD, simulated by its owner, Rapier's
    /// default material, in every collision group, not a sensor.
    pub fn new(shape: Shape) -> Self {
        Self {
            shape,
            density: 1000.0,
            ccd: false,
            motion: Motion::Simulated,
            material: Material::default(),
            groups: Groups::default(),
            sensor: false,
        }
    }

    /// Moved by its owner as `motion` says (simulated, kinematic or still).
    pub fn motion(self, motion: Motion) -> Self {
        Self { motion, ..self }
    }

    /// With `material` (friction, restitution, damping) whole.
    pub fn material(self, material: Material) -> Self {
        Self { material, ..self }
    }

    /// With friction coefficient `friction`.
    pub fn friction(mut self, friction: f32) -> Self {
        self.material.friction = friction;
        self
    }

    /// With restitution `restitution` (0: no bounce, 1: a perfect one).
    pub fn restitution(mut self, restitution: f32) -> Self {
        self.material.restitution = restitution;
        self
    }

    /// With linear and angular damping, 1/s.
    pub fn damping(mut self, linear: f32, angular: f32) -> Self {
        self.material.linear_damping = linear;
        self.material.angular_damping = angular;
        self
    }

    /// In the groups `memberships`, meeting bodies in `filter` (see [`Groups`]).
    pub fn groups(self, memberships: u32, filter: u32) -> Self {
        Self {
            groups: Groups {
                memberships,
                filter,
            },
            ..self
        }
    }

    /// A sensor (or not): it reports what enters and leaves it and pushes nothing.
    pub fn sensor(self, sensor: bool) -> Self {
        Self { sensor, ..self }
    }

    /// With `density`, kg/m³ (mass = density × volume).
    pub fn density(self, density: f32) -> Self {
        Self { density, ..self }
    }

    /// With continuous collision detection on or off (on for fast bodies that must not
    /// tunnel through thin ones).
    pub fn ccd(self, ccd: bool) -> Self {
        Self { ccd, ..self }
    }
}

impl EntityState {
    /// Entity `id`, owned by `owner`, with `body`: at the origin, unrotated, at rest, at tick
    /// 0 and epoch 0 (what a spawn needs; the cluster fills in the rest as it runs).
    pub fn new(id: EntityId, owner: ClusterId, body: BodySpec) -> Self {
        Self {
            id,
            cluster_id: owner,
            tick: 0,
            epoch: 0,
            position: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
            linvel: [0.0; 3],
            angvel: [0.0; 3],
            body,
        }
    }

    /// At `position`, metres.
    pub fn at(self, position: [f32; 3]) -> Self {
        Self { position, ..self }
    }

    /// Turned by the unit quaternion `rotation`, `[x, y, z, w]`.
    pub fn rotated(self, rotation: [f32; 4]) -> Self {
        Self { rotation, ..self }
    }

    /// Moving at `linvel`, m/s.
    pub fn velocity(self, linvel: [f32; 3]) -> Self {
        Self { linvel, ..self }
    }

    /// Spinning at `angvel`, rad/s.
    pub fn spin(self, angvel: [f32; 3]) -> Self {
        Self { angvel, ..self }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_built_state_is_the_literal_it_stands_for() {
        let (id, owner) = (EntityId::from_u128(7), ClusterId::from_u128(9));
        let built = EntityState::new(id, owner, BodySpec::new(Shape::ball(0.25)).ccd(true))
            .at([1.0, 2.0, 3.0])
            .rotated([0.0, 1.0, 0.0, 0.0])
            .velocity([4.0, 0.0, 0.0])
            .spin([0.0, 0.0, 5.0]);
        let literal = EntityState {
            id,
            cluster_id: owner,
            tick: 0,
            epoch: 0,
            position: [1.0, 2.0, 3.0],
            rotation: [0.0, 1.0, 0.0, 0.0],
            linvel: [4.0, 0.0, 0.0],
            angvel: [0.0, 0.0, 5.0],
            body: BodySpec {
                shape: Shape::Ball { radius: 0.25 },
                density: 1000.0,
                ccd: true,
                motion: Motion::Simulated,
                material: Material::default(),
                groups: Groups::default(),
                sensor: false,
            },
        };
        assert_eq!(built, literal);
    }

    #[test]
    fn every_spec_field_has_a_setter() {
        let spec = BodySpec::new(Shape::capsule(0.5, 0.25))
            .density(300.0)
            .ccd(true)
            .motion(Motion::Kinematic)
            .friction(0.9)
            .restitution(0.7)
            .damping(0.1, 0.2)
            .groups(0b01, 0b10)
            .sensor(true);
        let literal = BodySpec {
            shape: Shape::capsule(0.5, 0.25),
            density: 300.0,
            ccd: true,
            motion: Motion::Kinematic,
            material: Material {
                friction: 0.9,
                restitution: 0.7,
                linear_damping: 0.1,
                angular_damping: 0.2,
            },
            groups: Groups {
                memberships: 0b01,
                filter: 0b10,
            },
            sensor: true,
        };
        assert_eq!(spec, literal);
        assert_eq!(
            BodySpec::new(Shape::ball(1.0))
                .material(literal.material)
                .material,
            literal.material
        );
    }
}
