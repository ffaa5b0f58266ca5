//! The numbers of a page: 16-bit scaled floats rounded up, positions on a page's grid,
//! octahedral normals, cone angles, variable-length integers, spheres about their node.

use glam::{Vec2, Vec3};

/// A 16-bit float for errors and radii, in units of the file's `scale` (a power of two): code 0 is
/// 0; code `c` > 0 is `(1 + M/1024) · 2^(E − 56)`, `E = (c − 1) >> 10`, `M = (c − 1) & 1023`, so
/// it spans 2^−56 to 2^8 of the scale at 0.1 % steps. Decoding is exact bit work: the reader gets
/// the writer's numbers on every machine.
pub(super) fn decode_scaled(code: u16, scale: f32) -> f32 {
    if code == 0 {
        return 0.0;
    }
    let c = code as u32 - 1;
    let (e, m) = (c >> 10, c & 1023);
    f32::from_bits(((e + 127 - 56) << 23) | (m << 13)) * scale
}

/// The smallest code whose value is at least `x` (≥ 0, finite); `None` past the largest.
pub(super) fn encode_scaled_up(x: f32, scale: f32) -> Option<u16> {
    if x <= 0.0 {
        return Some(0);
    }
    let y = x / scale;
    let bits = y.to_bits();
    let e = (bits >> 23) as i32 - 127 + 56;
    let mut code = if e < 0 {
        1
    } else {
        let m = (bits >> 13) & 1023;
        let c = ((e as u32) << 10 | m) + 1;
        if bits & 0x1fff != 0 { c + 1 } else { c }
    };
    // Division rounds: step up until the decoded value holds `x`.
    while code <= u16::MAX as u32 && decode_scaled(code as u16, scale) < x {
        code += 1;
    }
    u16::try_from(code).ok()
}

/// The power of two at or above `x` (the tree's extent), the unit of [`decode_scaled`].
pub fn scale_for(x: f32) -> f32 {
    let x = x.max(f32::MIN_POSITIVE);
    let e = x.log2().ceil().clamp(-120.0, 120.0) as i32;
    2f32.powi(e)
}

/// `x` (≥ 0; anything below is 0, NaN too) to the nearest integer, halves up, saturating: a
/// conversion, where `f32::round` is a call into libm on the baseline x86-64 target.
pub(super) fn nearest(x: f32) -> u32 {
    (x + 0.5) as u32
}

/// A page's box and how a 16-bit coordinate maps into it.
#[derive(Clone, Copy)]
pub(super) struct Grid {
    pub(super) lo: Vec3,
    pub(super) step: Vec3,
    /// `1 / step` (0 where the step is): the writer's, to multiply instead of divide.
    pub(super) inverse: Vec3,
}

impl Grid {
    pub(super) fn new(lo: Vec3, hi: Vec3) -> Grid {
        let step = (hi - lo) / 65535.0;
        Grid {
            lo,
            step,
            inverse: step
                .to_array()
                .map(|s| if s > 0.0 { 1.0 / s } else { 0.0 })
                .into(),
        }
    }
    /// The nearest code (give or take a rounding: [`Grid::decode`] of it is what is stored).
    pub(super) fn encode(&self, p: Vec3) -> [u16; 3] {
        ((p - self.lo) * self.inverse)
            .to_array()
            .map(|q| nearest(q).min(65535) as u16)
    }
    pub(super) fn decode(&self, c: [u16; 3]) -> Vec3 {
        self.lo + Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * self.step
    }
}

/// Octahedral coding of a unit vector in `bits` per component (Cigolle et al., *A survey of
/// efficient representations for independent unit vectors*, JCGT 2014); zero stays zero.
pub(super) fn oct_encode(v: Vec3, bits: u32) -> [u16; 2] {
    let max = ((1u32 << bits) - 1) as f32;
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    if l1.is_nan() || l1 <= 0.0 {
        return [0, 0];
    }
    let p = Vec2::new(v.x, v.y) / l1;
    let p = if v.z < 0.0 {
        (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * Vec2::new(sign(p.x), sign(p.y))
    } else {
        p
    };
    // Code 0 (both) stands for zero: the grid starts at 1.
    let q = |x: f32| (nearest((x * 0.5 + 0.5) * (max - 1.0)) + 1).min(max as u32) as u16;
    [q(p.x), q(p.y)]
}

pub(super) fn sign(x: f32) -> f32 {
    if x >= 0.0 { 1.0 } else { -1.0 }
}

pub(super) fn oct_decode(c: [u16; 2], bits: u32) -> Vec3 {
    if c == [0, 0] {
        return Vec3::ZERO;
    }
    let max = ((1u32 << bits) - 1) as f32;
    let f = |x: u16| ((x as f32 - 1.0) / (max - 1.0)) * 2.0 - 1.0;
    let (x, y) = (f(c[0]), f(c[1]));
    let z = 1.0 - x.abs() - y.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - y.abs()) * sign(x), (1.0 - x.abs()) * sign(y))
    } else {
        (x, y)
    };
    Vec3::new(x, y, z).normalize_or_zero()
}

/// A unit normal (or zero) in three bytes: its two 12-bit octahedral codes `a`, `b` as
/// `a & 255`, `a >> 8 | (b & 15) << 4`, `b >> 4`.
pub(super) fn normal_bytes(n: Vec3) -> [u8; 3] {
    let [a, b] = oct_encode(n, NORMAL_BITS);
    [a as u8, (a >> 8) as u8 | (b << 4) as u8, (b >> 4) as u8]
}

pub(super) fn normal_of(bytes: [u8; 3]) -> Vec3 {
    let [a, b, c] = bytes.map(u16::from);
    oct_decode([a | (b & 0xf) << 8, b >> 4 | c << 4], NORMAL_BITS)
}

/// Cone cosines as a byte, rounded down (a wider cone): 0 is −1, every direction.
pub(super) fn cone_code_down(cos: f32) -> u8 {
    ((cos.clamp(-1.0, 1.0) + 1.0) * 127.5).floor() as u8
}

pub(super) fn cone_decode(code: u8) -> f32 {
    code as f32 / 127.5 - 1.0
}

/// Cone axes: 8 bits a component; normals: 12 (three bytes for both).
pub(super) const CONE_BITS: u32 = 8;
pub(super) const NORMAL_BITS: u32 = 12;

pub(super) fn put_varint(out: &mut Vec<u8>, mut x: u64) {
    while x >= 0x80 {
        out.push((x as u8) | 0x80);
        x >>= 7;
    }
    out.push(x as u8);
}

/// A triangle's corners as the pages code them: the first corner's difference from `first` (the
/// previous triangle's first corner, which it becomes), the others' from the first, zigzagged.
pub(super) fn put_triangle(out: &mut Vec<u8>, t: [u32; 3], first: &mut i64) {
    let c0 = t[0] as i64;
    put_varint(out, zigzag(c0 - *first));
    *first = c0;
    put_varint(out, zigzag(t[1] as i64 - c0));
    put_varint(out, zigzag(t[2] as i64 - c0));
}

pub(super) fn zigzag(x: i64) -> u64 {
    ((x << 1) ^ (x >> 63)) as u64
}

pub(super) fn unzigzag(x: u64) -> i64 {
    (x >> 1) as i64 ^ -((x & 1) as i64)
}

/// A sphere's centre as stored: its node's position plus an offset in 127ths of the radius on
/// each axis (the centre lies within the radius of the position, which the sphere holds).
pub(super) fn sphere_center(position: Vec3, offset: [i8; 3], radius: f32) -> Vec3 {
    position + Vec3::new(offset[0] as f32, offset[1] as f32, offset[2] as f32) * (radius / 127.0)
}

/// A node's stored sphere: an offset of its centre from `position` (stored) and a radius code
/// such that the sphere holds the tree's sphere (`center`, `radius`) with every position moved
/// by up to `moved`, and each of `children`'s stored spheres; `scale` is the radius code's unit.
pub(super) fn store_sphere(
    position: Vec3,
    (center, radius): (Vec3, f32),
    moved: f32,
    children: &[(Vec3, f32)],
    scale: f32,
) -> ([i8; 3], u16) {
    let need = |c: Vec3| {
        let mut r = radius + c.distance(center) + moved;
        for &(cc, cr) in children {
            r = r.max(crate::mesh::diagonal_of(c - cc) + cr);
        }
        r.max(c.distance(position)) * (1.0 + 4e-6)
    };
    let code = |r: f32| encode_scaled_up(r, scale).expect("radii lie within 2^8 of the extent");
    // The offset is in units of the radius it is stored with: try, and grow the radius until the
    // sphere holds; a centre at the position itself always does.
    let mut guess = code(need(center).max(center.distance(position)));
    for _ in 0..8 {
        let r = decode_scaled(guess, scale);
        if r <= 0.0 {
            break;
        }
        let offset = ((center - position) / r * 127.0)
            .to_array()
            .map(|x| (nearest(x + 127.0) as i32 - 127).clamp(-127, 127) as i8);
        let c = sphere_center(position, offset, r);
        let want = code(need(c));
        if want <= guess {
            return (offset, guess);
        }
        guess = want;
    }
    ([0; 3], code(need(position)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    pub(super) fn scaled_codes_round_up_and_decode_exactly() {
        for scale in [1.0f32, 0.25, 1024.0] {
            let mut x = 1e-12f32;
            while x < 100.0 * scale {
                let c = encode_scaled_up(x, scale).expect("in range");
                let d = decode_scaled(c, scale);
                assert!(d >= x, "{x} coded to {d}");
                assert!(d <= x * 1.002 || c == 1, "{x} coded to {d}: a step too far");
                x *= 1.37;
            }
        }
        assert_eq!(encode_scaled_up(0.0, 1.0), Some(0));
        assert_eq!(decode_scaled(0, 1.0), 0.0);
    }

    #[test]
    pub(super) fn octahedral_normals_come_back_within_a_tenth_of_a_degree() {
        let mut s = 12345u32;
        for _ in 0..10_000 {
            let mut r = || {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (s >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
            };
            let v = Vec3::new(r(), r(), r()).normalize_or_zero();
            if v == Vec3::ZERO {
                continue;
            }
            let back = oct_decode(oct_encode(v, NORMAL_BITS), NORMAL_BITS);
            assert!(
                v.dot(back) > (0.1f32.to_radians()).cos(),
                "{v} came back {back}"
            );
        }
        assert_eq!(oct_decode(oct_encode(Vec3::ZERO, 12), 12), Vec3::ZERO);
    }

    #[test]
    pub(super) fn varints_and_zigzag_round_trip() {
        for x in [
            0i64,
            1,
            -1,
            63,
            -64,
            1 << 20,
            -(1 << 31),
            i64::from(u32::MAX),
        ] {
            assert_eq!(unzigzag(zigzag(x)), x);
        }
    }
}
