//! Quantized motion: fixed-point positions, smallest-three rotations, half-float velocities.

use half::f16;

use super::WireResult;
use super::layout::malformed;

/// Fixed-point steps per metre of a quantized position.
pub const POSITION_STEPS_PER_METRE: f32 = 1024.0;

/// Largest velocity component a quantized frame carries (the largest finite half float);
/// larger ones are clamped to it.
pub const MAX_QUANTIZED_VELOCITY: f32 = 65504.0;

pub(super) fn quantize_position(position: [f32; 3]) -> [u8; 12] {
    let mut bytes = [0u8; 12];
    for (slot, x) in bytes.chunks_exact_mut(4).zip(position) {
        // `as` saturates at the i32 range (and sends NaN to 0).
        let steps = (x * POSITION_STEPS_PER_METRE).round() as i32;
        slot.copy_from_slice(&steps.to_le_bytes());
    }
    bytes
}

pub(super) fn read_position(bytes: &[u8; 12]) -> [f32; 3] {
    let mut position = [0f32; 3];
    for (x, b) in position.iter_mut().zip(bytes.chunks_exact(4)) {
        *x = i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32 / POSITION_STEPS_PER_METRE;
    }
    position
}

const ROTATION_STEPS: f32 = 16383.0;

/// Smallest three: the index of the largest component (2 bits), then the other three, each
/// within ±1/√2, in 15 bits each; the sign is chosen so the largest is positive.
pub(super) fn quantize_rotation(rotation: [f32; 4]) -> [u8; 6] {
    let norm = rotation.iter().map(|c| c * c).sum::<f32>().sqrt();
    let q = if norm.is_finite() && norm > 0.0 {
        rotation.map(|c| c / norm)
    } else {
        [0.0, 0.0, 0.0, 1.0]
    };
    let largest = (0..4)
        .max_by(|&a, &b| q[a].abs().total_cmp(&q[b].abs()))
        .unwrap_or(3);
    let sign = if q[largest] < 0.0 { -1.0 } else { 1.0 };
    let mut bits = (largest as u64) << 45;
    let mut shift = 30;
    for (i, &c) in q.iter().enumerate() {
        if i == largest {
            continue;
        }
        let scaled = (c * sign * std::f32::consts::SQRT_2).clamp(-1.0, 1.0);
        let step = ((scaled * ROTATION_STEPS).round() + ROTATION_STEPS) as u64;
        bits |= step << shift;
        shift -= 15;
    }
    let mut bytes = [0u8; 6];
    bytes.copy_from_slice(&bits.to_le_bytes()[..6]);
    bytes
}

pub(super) fn read_rotation(bytes: &[u8; 6]) -> WireResult<[f32; 4]> {
    let mut eight = [0u8; 8];
    eight[..6].copy_from_slice(bytes);
    let bits = u64::from_le_bytes(eight);
    let largest = ((bits >> 45) & 3) as usize;
    let mut q = [0f32; 4];
    let mut shift = 30;
    let mut sum = 0.0;
    for (i, c) in q.iter_mut().enumerate() {
        if i == largest {
            continue;
        }
        let step = ((bits >> shift) & 0x7fff) as f32;
        *c = (step - ROTATION_STEPS) / ROTATION_STEPS / std::f32::consts::SQRT_2;
        sum += *c * *c;
        shift -= 15;
    }
    if bits >> 47 != 0 || sum > 1.0 {
        return Err(malformed("rotation is not a unit quaternion"));
    }
    // Unit by construction, to f32 rounding.
    q[largest] = (1.0 - sum).sqrt();
    Ok(q)
}

pub(super) fn halves(values: [f32; 3]) -> [u8; 6] {
    let mut bytes = [0u8; 6];
    for (slot, v) in bytes.chunks_exact_mut(2).zip(values) {
        let bounded = v.clamp(-MAX_QUANTIZED_VELOCITY, MAX_QUANTIZED_VELOCITY);
        slot.copy_from_slice(&f16::from_f32(bounded).to_le_bytes());
    }
    bytes
}

pub(super) fn read_halves(bytes: &[u8; 6]) -> [f32; 3] {
    let mut values = [0f32; 3];
    for (v, b) in values.iter_mut().zip(bytes.chunks_exact(2)) {
        *v = half_to_f32(u16::from_le_bytes([b[0], b[1]]));
    }
    values
}

/// An IEEE 754 binary16 as f32 (exact: every half is an f32). Written out rather than through
/// `half`, whose portable conversion is a call per value: a receiver reads six a state.
#[inline]
pub(super) fn half_to_f32(bits: u16) -> f32 {
    let sign = u32::from(bits & 0x8000) << 16;
    let exponent = u32::from(bits >> 10) & 0x1f;
    let mantissa = u32::from(bits & 0x3ff);
    match exponent {
        // Zero and subnormals: mantissa × 2⁻²⁴.
        0 => {
            let magnitude = mantissa as f32 * (1.0 / 16_777_216.0);
            f32::from_bits(sign | magnitude.to_bits())
        }
        // Infinity and NaN.
        0x1f => f32::from_bits(sign | 0x7f80_0000 | (mantissa << 13)),
        // Normal: rebias the exponent from 15 to 127.
        _ => f32::from_bits(sign | ((exponent + 112) << 23) | (mantissa << 13)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rotation angle between two unit quaternions, from their difference: the arc cosine of
    /// their dot product, at f32 precision, makes ~7e-4 rad of nothing.
    fn angle_between(a: [f32; 4], b: [f32; 4]) -> f32 {
        let sign = if a.iter().zip(&b).map(|(x, y)| x * y).sum::<f32>() < 0.0 {
            -1.0
        } else {
            1.0
        };
        let d = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - sign * y).powi(2))
            .sum::<f32>();
        4.0 * (d.sqrt() / 2.0).asin()
    }

    #[test]
    fn smallest_three_round_trips_within_two_ten_thousandths_of_a_radian() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..10_000 {
            let q = [next(), next(), next(), next()];
            let norm = q.iter().map(|c| c * c).sum::<f32>().sqrt();
            let q = q.map(|c| c / norm);
            let back = read_rotation(&quantize_rotation(q)).expect("a unit quaternion");
            let angle = angle_between(q, back);
            assert!(angle < 2e-4, "{q:?} came back as {back:?}: {angle} rad off");
        }
    }

    #[test]
    fn every_half_float_reads_as_the_half_crate_reads_it() {
        for bits in 0..=u16::MAX {
            let ours = half_to_f32(bits);
            let theirs = f16::from_bits(bits).to_f32();
            assert!(
                ours.to_bits() == theirs.to_bits() || (ours.is_nan() && theirs.is_nan()),
                "{bits:#06x}: {ours} against {theirs}"
            );
        }
    }

    #[test]
    fn positions_round_trip_within_half_a_step() {
        for x in [0.0, 0.000_49, -1.5, 123.456_7, -4_000.25, 999_999.0] {
            let [back, ..] = read_position(&quantize_position([x, 0.0, 0.0]));
            // Past a few thousand metres the f32 itself is coarser than the step.
            let tolerance = 0.5 / POSITION_STEPS_PER_METRE + x.abs() * f32::EPSILON;
            assert!((back - x).abs() <= tolerance, "{x} came back as {back}");
        }
    }
}
