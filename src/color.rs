//! The sRGB transfer function (IEC 61966-2-1), both ways, for the places that turn linear colours
//! into display bytes or back.

/// A linear channel, clamped to [0, 1], as an 8-bit sRGB value.
pub fn srgb8(linear: f32) -> u8 {
    let l = linear.clamp(0.0, 1.0);
    let s = if l <= 0.003_130_8 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

/// An sRGB-encoded channel in [0, 1] as linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_byte_comes_back() {
        for b in 0..=255u8 {
            assert_eq!(super::srgb8(super::srgb_to_linear(b as f32 / 255.0)), b);
        }
    }
}
