//! How far one picture is from another, judged by a tolerance that names what it allows: the
//! mean difference (a uniform shift), a percentile (a few pixels off) and the largest one (one
//! pixel far off), after wgpu's `tests/src/image.rs`. A seam one pixel wide shows in the
//! percentile and the maximum long before it moves the mean.

use image::RgbaImage;

/// The differences between two pictures of one size, in 1/255.
#[derive(Clone, Copy, Debug)]
pub struct Difference {
    /// Mean absolute difference over every channel of every pixel.
    pub mean: f64,
    /// The 99th percentile of the pixels' differences (a pixel's: its largest channel's).
    pub p99: u8,
    /// The largest difference of any channel of any pixel, and where it is.
    pub max: u8,
    pub max_at: (u32, u32),
    /// Pixels that differ at all.
    pub differing: usize,
}

impl Difference {
    /// Compares `a` with `b` (the same size: a difference in size panics, naming both).
    pub fn between(a: &RgbaImage, b: &RgbaImage) -> Difference {
        assert_eq!(a.dimensions(), b.dimensions(), "pictures of different sizes");
        let mut per_pixel: Vec<u8> = Vec::with_capacity(a.pixels().len());
        let (mut total, mut max, mut max_at) = (0u64, 0u8, (0, 0));
        for ((x, y, p), q) in a.enumerate_pixels().zip(b.pixels()) {
            let worst = (0..4).map(|c| p[c].abs_diff(q[c])).max().unwrap_or(0);
            total += (0..4).map(|c| u64::from(p[c].abs_diff(q[c]))).sum::<u64>();
            if worst > max {
                (max, max_at) = (worst, (x, y));
            }
            per_pixel.push(worst);
        }
        let differing = per_pixel.iter().filter(|&&d| d > 0).count();
        per_pixel.sort_unstable();
        let p99 = per_pixel.get((per_pixel.len() * 99).div_ceil(100).saturating_sub(1)).copied().unwrap_or(0);
        let mean = total as f64 / (a.as_raw().len().max(1)) as f64;
        Difference { mean, p99, max, max_at, differing }
    }
}

impl std::fmt::Display for Difference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "mean {:.4}/255, 99th percentile {}/255, maximum {}/255 at {:?}, {} pixels differ",
            self.mean, self.p99, self.max, self.max_at, self.differing
        )
    }
}

/// What a comparison allows, each limit in 1/255 (inclusive).
#[derive(Clone, Copy, Debug)]
pub struct Tolerance {
    pub mean: f64,
    pub p99: u8,
    pub max: u8,
}

impl Tolerance {
    /// `Ok` when `d` is within every limit; otherwise each limit it passes, named.
    pub fn check(&self, what: &str, d: &Difference) -> Result<(), String> {
        let mut over = Vec::new();
        if d.mean > self.mean {
            over.push(format!("mean {:.4} > {}", d.mean, self.mean));
        }
        if d.p99 > self.p99 {
            over.push(format!("99th percentile {} > {}", d.p99, self.p99));
        }
        if d.max > self.max {
            over.push(format!("maximum {} > {} at {:?}", d.max, self.max, d.max_at));
        }
        if over.is_empty() { Ok(()) } else { Err(format!("{what}: {} ({d})", over.join(", "))) }
    }
}
