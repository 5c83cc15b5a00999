//! A rectangle of a view's image: what one dispatch of a view's passes renders (the whole
//! image, a tile, a preview's).

/// Pixels `x0..x1` by `y0..y1` of a view's image (end exclusive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Region {
    /// The whole of an image of `size` pixels.
    pub fn whole([w, h]: [u32; 2]) -> Region {
        Region { x0: 0, y0: 0, x1: w, y1: h }
    }

    /// The part of the region inside an image of `size` pixels.
    pub fn within(&self, [w, h]: [u32; 2]) -> Region {
        Region { x0: self.x0.min(w), y0: self.y0.min(h), x1: self.x1.min(w), y1: self.y1.min(h) }
    }

    /// The number of pixels in the region.
    pub fn pixels(&self) -> u64 {
        u64::from(self.x1.saturating_sub(self.x0)) * u64::from(self.y1.saturating_sub(self.y0))
    }
}
