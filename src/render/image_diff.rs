//! Image comparison for LOD-versus-full renders and golden tests: PSNR, the share of pixels that
//! differ visibly, and pictures of the difference.

use image::{Rgba, RgbaImage};

/// A pixel "differs" when one of its channels is off by more than this (of 255).
pub const VISIBLE_DIFFERENCE: u8 = 8;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// Peak signal-to-noise ratio over RGB, in dB (infinite for identical images).
    pub psnr_db: f64,
    /// Share of pixels with a channel off by more than [`VISIBLE_DIFFERENCE`].
    pub differing: f64,
    /// Largest channel difference.
    pub max_difference: u8,
}

/// Compares two images of the same size.
pub fn compare(a: &RgbaImage, b: &RgbaImage) -> Comparison {
    assert_eq!(a.dimensions(), b.dimensions(), "compare images of one size");
    let (mut squared, mut differing, mut max) = (0u64, 0u64, 0u8);
    for (p, q) in a.pixels().zip(b.pixels()) {
        let mut worst = 0;
        for c in 0..3 {
            let d = p[c].abs_diff(q[c]);
            squared += d as u64 * d as u64;
            worst = worst.max(d);
        }
        max = max.max(worst);
        differing += (worst > VISIBLE_DIFFERENCE) as u64;
    }
    let pixels = (a.width() as u64 * a.height() as u64).max(1);
    let mse = squared as f64 / (pixels * 3) as f64;
    Comparison {
        psnr_db: if mse == 0.0 {
            f64::INFINITY
        } else {
            10.0 * (255.0 * 255.0 / mse).log10()
        },
        differing: differing as f64 / pixels as f64,
        max_difference: max,
    }
}

/// The absolute difference, amplified 4× so that small errors show.
pub fn difference(a: &RgbaImage, b: &RgbaImage) -> RgbaImage {
    RgbaImage::from_fn(a.width(), a.height(), |x, y| {
        let (p, q) = (a.get_pixel(x, y), b.get_pixel(x, y));
        let d = |c: usize| p[c].abs_diff(q[c]).saturating_mul(4);
        Rgba([d(0), d(1), d(2), 255])
    })
}

/// Images side by side, left to right, on one row.
pub fn side_by_side(images: &[&RgbaImage]) -> RgbaImage {
    let height = images.iter().map(|i| i.height()).max().unwrap_or(1);
    let width = images.iter().map(|i| i.width()).sum::<u32>().max(1);
    let mut out = RgbaImage::from_pixel(width, height, Rgba([0, 0, 0, 255]));
    let mut x = 0;
    for image in images {
        image::imageops::replace(&mut out, *image, x as i64, 0);
        x += image.width();
    }
    out
}

/// A contact sheet: the frames scaled to `thumb_width` in a grid `columns` wide.
pub fn contact_sheet(frames: &[RgbaImage], columns: u32, thumb_width: u32) -> RgbaImage {
    let Some(first) = frames.first() else {
        return RgbaImage::new(1, 1);
    };
    let thumb_height =
        (thumb_width as u64 * first.height() as u64 / first.width().max(1) as u64).max(1) as u32;
    let columns = columns.max(1);
    let rows = (frames.len() as u32).div_ceil(columns);
    let gap = 4;
    let mut out = RgbaImage::from_pixel(
        columns * (thumb_width + gap) + gap,
        rows * (thumb_height + gap) + gap,
        Rgba([16, 16, 20, 255]),
    );
    for (i, frame) in frames.iter().enumerate() {
        let thumb = image::imageops::resize(
            frame,
            thumb_width,
            thumb_height,
            image::imageops::FilterType::Triangle,
        );
        let (c, r) = (i as u32 % columns, i as u32 / columns);
        image::imageops::replace(
            &mut out,
            &thumb,
            (gap + c * (thumb_width + gap)) as i64,
            (gap + r * (thumb_height + gap)) as i64,
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn psnr_and_share() {
        let a = RgbaImage::from_pixel(10, 10, Rgba([100, 100, 100, 255]));
        let mut b = a.clone();
        assert!(compare(&a, &b).psnr_db.is_infinite());
        b.put_pixel(0, 0, Rgba([110, 100, 100, 255]));
        let c = compare(&a, &b);
        assert_eq!(c.differing, 0.01);
        assert_eq!(c.max_difference, 10);
        // MSE = 100 / 300 → PSNR = 10 log10(65025 · 3) ≈ 52.9 dB.
        assert!((c.psnr_db - 52.90).abs() < 0.01, "{}", c.psnr_db);
    }
}
