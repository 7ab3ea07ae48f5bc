//! Plain Rapier, no seam: a scene's bodies as one Rapier world, stepped and timed, as the
//! anchor `seam capacity` measures seam against.
//!
//! The world is what seam's single world would be (the same shapes, masses, materials,
//! velocities, gravity, step and speed cap) with nothing of seam around it: no entities, no
//! events collected, no replication. `seam capacity` writes a [`WorldSpec`] as JSON and runs
//! the `seam-anchor` binary on it, built with and without Rapier's `parallel` feature, so each
//! build steps the same world.

use rapier3d::prelude::*;
use serde::{Deserialize, Serialize};

/// A collision shape.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ShapeSpec {
    /// A sphere of this radius, m.
    Ball {
        /// Radius, m.
        radius: f32,
    },
    /// A box of these half sizes, m.
    Cuboid {
        /// Half sizes, m.
        half_extents: [f32; 3],
    },
    /// A capsule along y.
    Capsule {
        /// Half the straight part, m.
        half_height: f32,
        /// Radius, m.
        radius: f32,
    },
}

impl ShapeSpec {
    fn shared(self) -> SharedShape {
        match self {
            ShapeSpec::Ball { radius } => SharedShape::ball(radius),
            ShapeSpec::Cuboid {
                half_extents: [x, y, z],
            } => SharedShape::cuboid(x, y, z),
            ShapeSpec::Capsule {
                half_height,
                radius,
            } => SharedShape::capsule_y(half_height, radius),
        }
    }
}

/// How a body moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Motion {
    /// Simulated.
    Dynamic,
    /// Moved by its velocity only.
    Kinematic,
    /// Never moves.
    Fixed,
}

/// One body and its collider.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BodySpec {
    /// Its shape.
    pub shape: ShapeSpec,
    /// How it moves.
    pub motion: Motion,
    /// kg/m³.
    pub density: f32,
    /// Position, m.
    pub position: [f32; 3],
    /// Orientation `[x, y, z, w]`.
    pub rotation: [f32; 4],
    /// m/s.
    pub linvel: [f32; 3],
    /// rad/s.
    pub angvel: [f32; 3],
    /// Friction coefficient.
    pub friction: f32,
    /// Restitution.
    pub restitution: f32,
    /// Linear and angular damping, 1/s.
    pub damping: [f32; 2],
    /// Continuous collision detection.
    pub ccd: bool,
}

/// A whole world.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorldSpec {
    /// m/s².
    pub gravity: [f32; 3],
    /// Step length, s.
    pub dt: f32,
    /// Largest linear speed, m/s.
    pub max_speed: f32,
    /// The bodies.
    pub bodies: Vec<BodySpec>,
}

/// A world built from a [`WorldSpec`].
pub struct PlainWorld {
    world: PhysicsWorld,
}

impl PlainWorld {
    /// The world of `spec`, every body inserted in its order.
    pub fn new(spec: &WorldSpec) -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = Vector::from_array(spec.gravity);
        world.integration_parameters.dt = spec.dt;
        world.integration_parameters.normalized_max_linear_velocity =
            spec.max_speed / world.integration_parameters.length_unit;
        for body in &spec.bodies {
            let kind = match body.motion {
                Motion::Dynamic => RigidBodyType::Dynamic,
                Motion::Kinematic => RigidBodyType::KinematicVelocityBased,
                Motion::Fixed => RigidBodyType::Fixed,
            };
            let [x, y, z, w] = body.rotation;
            let pose = Pose::from_parts(
                Vector::from_array(body.position),
                Rotation::from_xyzw(x, y, z, w).normalize(),
            );
            let rigid = RigidBodyBuilder::new(kind)
                .pose(pose)
                .linvel(Vector::from_array(body.linvel))
                .angvel(Vector::from_array(body.angvel))
                .ccd_enabled(body.ccd)
                .linear_damping(body.damping[0])
                .angular_damping(body.damping[1]);
            let collider = ColliderBuilder::new(body.shape.shared())
                .density(body.density)
                .friction(body.friction)
                .restitution(body.restitution);
            world.insert(rigid, collider);
        }
        Self { world }
    }

    /// One step.
    pub fn step(&mut self) {
        self.world.step();
    }

    /// Bodies in the world.
    pub fn len(&self) -> usize {
        self.world.bodies.len()
    }

    /// Whether the world has no body.
    pub fn is_empty(&self) -> bool {
        self.world.bodies.is_empty()
    }
}

/// What one run of a world measured: each tick's wall time and the CPU time the whole
/// process spent in it (every thread's: Rapier's `parallel` build steps on several).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Bodies in the world.
    pub bodies: usize,
    /// Worker threads Rapier could step on (1 without `parallel`).
    pub threads: usize,
    /// Whether this build has Rapier's `parallel` feature.
    pub parallel: bool,
    /// Whether this build has Rapier's `enhanced-determinism` feature.
    pub determinism: bool,
    /// Each tick's wall time, ns.
    pub wall_ns: Vec<u64>,
    /// Each tick's process CPU time, ns.
    pub cpu_ns: Vec<u64>,
}

/// Steps `world` `ticks` times, `rate` ticks a second (0: back to back), timing each step.
pub fn run(world: &mut PlainWorld, ticks: u64, rate: f64) -> Timings {
    let period = (rate > 0.0).then(|| std::time::Duration::from_secs_f64(1.0 / rate));
    let start = std::time::Instant::now();
    let mut timings = Timings {
        bodies: world.len(),
        threads: threads(),
        parallel: cfg!(feature = "parallel"),
        determinism: cfg!(feature = "determinism"),
        ..Timings::default()
    };
    for tick in 0..ticks {
        if let Some(period) = period {
            let due = start + period.mul_f64(tick as f64);
            let now = std::time::Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
        }
        let (wall, cpu) = (std::time::Instant::now(), process_cpu_ns());
        world.step();
        timings.wall_ns.push(wall.elapsed().as_nanos() as u64);
        timings.cpu_ns.push(process_cpu_ns().saturating_sub(cpu));
    }
    timings
}

/// The CPU time this process has spent, every thread's, ns.
pub fn process_cpu_ns() -> u64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ProcessCPUTime);
    t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64
}

#[cfg(feature = "parallel")]
fn threads() -> usize {
    rapier3d::rayon::current_num_threads()
}

#[cfg(not(feature = "parallel"))]
fn threads() -> usize {
    1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ball falling onto a fixed box comes to rest on it.
    #[test]
    fn a_ball_lands_on_a_box() {
        let ball = BodySpec {
            shape: ShapeSpec::Ball { radius: 0.5 },
            motion: Motion::Dynamic,
            density: 1.0,
            position: [0.0, 3.0, 0.0],
            rotation: [0.0, 0.0, 0.0, 1.0],
            linvel: [0.0; 3],
            angvel: [0.0; 3],
            friction: 0.5,
            restitution: 0.0,
            damping: [0.0; 2],
            ccd: false,
        };
        let floor = BodySpec {
            shape: ShapeSpec::Cuboid {
                half_extents: [5.0, 0.5, 5.0],
            },
            motion: Motion::Fixed,
            position: [0.0, 0.0, 0.0],
            ..ball
        };
        let spec = WorldSpec {
            gravity: [0.0, -9.81, 0.0],
            dt: 1.0 / 60.0,
            max_speed: 400.0,
            bodies: vec![ball, floor],
        };
        let mut world = PlainWorld::new(&spec);
        let timings = run(&mut world, 180, 0.0);
        assert_eq!(timings.wall_ns.len(), 180);
        assert_eq!(timings.bodies, 2);
        let y = world
            .world
            .bodies
            .iter()
            .next()
            .map(|(_, b)| b.translation().y);
        let y = y.expect("the ball");
        assert!((y - 1.0).abs() < 0.05, "the ball rests at y = {y}");
    }
}
