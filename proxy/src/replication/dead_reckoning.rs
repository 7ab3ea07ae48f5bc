//! Where a kinematic proxy aims between replication frames.
//!
//! A kinematic velocity-based proxy is given, at each frame of its entity, the velocity that
//! carries it one step along the way to where the entity will be at the next frame (its
//! replicated pose advanced by its replicated velocities), and keeps that velocity until then.
//! Position and orientation are paced alike: a step covers `1 / ticks` of the way, so over the
//! `ticks` steps until the next frame the proxy arrives where the entity is expected. (An
//! orientation aimed to be reached in one step and then held for `ticks` steps would turn
//! `ticks` times too far: a resting crate's proxy spun at 45 rad/s with a frame every 8 ticks.)

use seam_sim::wire::EntityState;

/// The pose one step along the way from the proxy's current pose `now` to where the entity
/// replicated as `state` will be `ahead` seconds later, reached in `ticks` steps; with the
/// entity's velocities.
pub(crate) fn aim(now: &EntityState, state: &EntityState, ahead: f32, ticks: f32) -> EntityState {
    let mut aim = *state;
    for k in 0..3 {
        let goal = state.position[k] + state.linvel[k] * ahead;
        aim.position[k] = now.position[k] + (goal - now.position[k]) / ticks;
    }
    let turn = state.angvel.map(|w| w * ahead);
    let goal = multiply(rotation_of(turn), state.rotation);
    aim.rotation = toward(now.rotation, goal, 1.0 / ticks);
    aim
}

/// The rotation by the rotation vector `v` (axis times angle), `[x, y, z, w]`.
fn rotation_of(v: [f32; 3]) -> [f32; 4] {
    let angle = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if angle < 1e-9 {
        return [0.0, 0.0, 0.0, 1.0];
    }
    let s = (angle / 2.0).sin() / angle;
    [v[0] * s, v[1] * s, v[2] * s, (angle / 2.0).cos()]
}

/// The product `a · b`: the rotation `b`, then `a`.
fn multiply(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    let [ax, ay, az, aw] = a;
    let [bx, by, bz, bw] = b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// The rotation `fraction` of the shortest way from `from` to `to` (a spherical step: a
/// constant turn rate, however large the turn).
fn toward(from: [f32; 4], to: [f32; 4], fraction: f32) -> [f32; 4] {
    let [x, y, z, w] = multiply(to, [-from[0], -from[1], -from[2], from[3]]);
    // q and -q are one rotation: go the short way.
    let (x, y, z, w) = if w < 0.0 {
        (-x, -y, -z, -w)
    } else {
        (x, y, z, w)
    };
    let half = w.min(1.0).acos();
    let sin = half.sin();
    if sin < 1e-7 {
        return from;
    }
    let scale = 2.0 * half * fraction / sin;
    multiply(rotation_of([x * scale, y * scale, z * scale]), from)
}

#[cfg(test)]
mod tests {
    use seam_sim::wire::{BodySpec, ClusterId, EntityId, Shape};

    use super::*;

    fn state(
        position: [f32; 3],
        rotation: [f32; 4],
        linvel: [f32; 3],
        angvel: [f32; 3],
    ) -> EntityState {
        let body = BodySpec::new(Shape::ball(0.3)).density(1.0);
        EntityState::new(EntityId::from_u128(1), ClusterId::from_u128(2), body)
            .at(position)
            .rotated(rotation)
            .velocity(linvel)
            .spin(angvel)
    }

    fn angle_between(a: [f32; 4], b: [f32; 4]) -> f32 {
        let dot: f32 = (0..4).map(|k| a[k] * b[k]).sum();
        2.0 * dot.abs().min(1.0).acos()
    }

    #[test]
    fn a_step_covers_its_share_of_the_way() {
        // A ball rolling at 3 m/s, spinning at 10 rad/s about z, replicated every 8 ticks.
        let dt = 1.0 / 60.0;
        let ticks = 8.0;
        let replicated = state(
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [3.0, 0.0, 0.0],
            [0.0, 0.0, 10.0],
        );
        let now = state([1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], [0.0; 3], [0.0; 3]);
        let aim = aim(&now, &replicated, dt * ticks, ticks);
        // One step of eight: 3 m/s × 8/60 s / 8 = 5 cm, and a turn of 10 rad/s × 1/60 s.
        assert!((aim.position[0] - 1.05).abs() < 1e-5, "{aim:?}");
        let turned = angle_between(aim.rotation, now.rotation);
        assert!(
            (turned - 10.0 * dt).abs() < 1e-3,
            "turned {turned} rad in a step"
        );
    }

    #[test]
    fn a_resting_body_stays_put_whichever_sign_its_quaternion_has() {
        let half = 0.26f32;
        let q = [0.0, 0.0, half.sin(), half.cos()];
        let negated = q.map(|c| -c);
        let replicated = state([0.0; 3], negated, [0.0; 3], [0.0; 3]);
        let now = state([0.0; 3], q, [0.0; 3], [0.0; 3]);
        let aim = aim(&now, &replicated, 8.0 / 60.0, 8.0);
        assert!(
            (0..4).all(|k| (aim.rotation[k] - q[k]).abs() < 1e-6),
            "{aim:?}"
        );
    }
}
