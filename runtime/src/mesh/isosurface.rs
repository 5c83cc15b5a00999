//! Surfaces from volumes: marching cubes over the voxel centres at a level, as an indexed
//! triangle mesh in patient space (RAS millimetres). For label or mask volumes choose a level
//! between the values (0.5 for a 0/1 mask), so that the surface runs between voxel centres.
//!
//! Our own implementation, not a crate's. Of the crates on crates.io, `mcubes` 0.1.7 (MIT) emits
//! a triangle soup (three unshared vertices per triangle), copies the whole volume to `f32`,
//! has no bound on its output and brings its own linear algebra crate; `isosurface`
//! 0.1.0-alpha.0 is an unmaintained alpha that samples implicit functions through its own
//! traits; `marching-cubes` 0.1.2 polygonises one cell at a time and leaves the mesh to the
//! caller; `fast-surface-nets` 0.2.1 is maintained but is Surface Nets, another algorithm (one
//! vertex per cell, off the level crossings), built on an older glam. None reads our stored
//! sample types without a full copy, shares vertices or stops at a triangle limit.
//!
//! The algorithm is the classic one (Lorensen and Cline): each cell of eight neighbouring voxel
//! centres is classified by which corners are inside (value `>= level`; NaN counts as below),
//! and the surface crosses each cell edge whose ends differ at the linearly interpolated point.
//! The 256-case triangulation table is not transcribed but generated once from a single rule:
//! on each cell face the crossings are joined in pairs, an ambiguous face (two diagonal inside
//! corners) cutting off each inside corner on its own, and the closed loops this draws on the
//! cell are triangulated with the shortest diagonals that run through the cell (none in a face).
//! Neighbouring cells share a face and so decide it alike, which makes the surface watertight and
//! manifold: every edge belongs to exactly two triangles, wound consistently. It is open only
//! where the inside reaches the volume's border.
//!
//! Vertices sit on cell edges and are shared through per-slice caches, so memory beyond the mesh
//! is a few slices (four slices of values in data units, five of vertex indices); the triangle
//! limit is checked before each cell adds its triangles. Normals are the negated gradient of the
//! values (central differences at the voxel centres, interpolated along the edge, transformed
//! to patient space by the inverse transpose), so they point from inside (`>= level`) to outside
//! (`< level`); where the gradient vanishes or is not finite (beside NaN or infinite samples) the
//! area-weighted normal of the faces is used instead. Samples exactly at the level put vertices
//! on voxel centres, where several may coincide: the triangles between them have no area but
//! keep the surface closed.

use std::sync::OnceLock;

use glam::{Mat3, Mat4, Vec3};

use super::{Limits, Mesh, MeshError, normals};
use crate::volume::Volume;

/// The name errors are reported under.
const SOURCE: &str = "isosurface";
/// No vertex yet on this edge.
const NONE: u32 = u32::MAX;
/// The most triangles one cell makes: a loop through 7 edges, as in the classic table.
const MAX_CASE_TRIANGLES: usize = 5;

/// The surface where `volume`'s data values cross `level` (data units), by marching cubes over
/// the voxel centres, in patient space (RAS mm, through `grid_to_world`).
///
/// The inside is where values are `>= level`; NaN samples count as outside. Triangles are
/// counter-clockwise seen from outside and the normals point outwards, from the inside towards
/// values below the level: away from bone in a CT at a bone level, away from the label in a mask
/// at 0.5. Vertices on the same voxel edge are shared. The mesh is closed except where the
/// inside touches the border of the volume.
///
/// Errors: a volume with fewer than 2 voxels along an axis, samples that do not fill `dims`, a
/// singular or non-finite `grid_to_world`, a level that is not finite or not above the minimum
/// and at most the maximum of the values (no surface), or a surface of more than
/// `limits.max_triangles` triangles (refused before they are made).
pub(crate) fn extract(volume: &Volume, level: f32, limits: &Limits) -> Result<Mesh, MeshError> {
    let transform = check(volume, level)?;
    let grid = Grid::new(volume);
    let mut builder = Builder::new(&grid, level, transform);
    march(grid, &mut builder, limits)?;
    if builder.indices.is_empty() {
        return Err(no_surface(volume, level));
    }
    Ok(builder.finish())
}

/// Refuses volumes and levels that cannot make a surface; the transform to patient space.
fn check(volume: &Volume, level: f32) -> Result<Transform, MeshError> {
    let [x, y, z] = volume.dims;
    if volume.dims.iter().any(|&d| d < 2) {
        let message =
            format!("the volume is {x}×{y}×{z} voxels: marching cubes needs at least 2 voxels along each axis");
        return Err(MeshError::shape(SOURCE, message));
    }
    if volume.voxel_count() != volume.samples.len() as u64 {
        let message = format!(
            "the volume has {} samples, but {x}×{y}×{z} voxels need {}",
            volume.samples.len(),
            volume.voxel_count()
        );
        return Err(MeshError::shape(SOURCE, message));
    }
    if !level.is_finite() {
        return Err(MeshError::shape(SOURCE, format!("the level {level} is not a number: choose a finite level")));
    }
    let [lo, hi] = volume.range;
    if !(lo < level && level <= hi) {
        return Err(no_surface(volume, level));
    }
    Transform::new(volume.grid_to_world).ok_or_else(|| {
        let message = "the volume's voxel-to-patient transform (grid_to_world) is singular or not finite: \
                       fix the volume's orientation header";
        MeshError::shape(SOURCE, message)
    })
}

fn no_surface(volume: &Volume, level: f32) -> MeshError {
    let [lo, hi] = volume.range;
    let message = format!(
        "no surface at level {level}: the values lie in [{lo}, {hi}], and the surface separates values \
         below the level from values at or above it: choose a level above {lo} and at most {hi}"
    );
    MeshError::shape(SOURCE, message)
}

/// Voxel index space to patient space.
struct Transform {
    grid_to_world: Mat4,
    /// Index-space gradients to patient-space gradients: the inverse transpose of the linear part.
    gradient: Mat3,
    /// Whether the transform mirrors (negative determinant), which reverses the winding.
    mirrors: bool,
}

impl Transform {
    fn new(grid_to_world: Mat4) -> Option<Transform> {
        let linear = Mat3::from_mat4(grid_to_world);
        let det = linear.determinant();
        if !grid_to_world.is_finite() || !det.is_finite() || det == 0.0 {
            return None;
        }
        let gradient = linear.inverse().transpose();
        gradient.is_finite().then_some(Transform { grid_to_world, gradient, mirrors: det < 0.0 })
    }
}

/// The volume's values in data units, a sliding window of four slices (z - 1 to z + 2 around the
/// cells being marched), slice `z` in `slices[z % 4]`.
struct Grid<'v> {
    volume: &'v Volume,
    nx: usize,
    ny: usize,
    nz: usize,
    slices: [Vec<f32>; 4],
    /// Slices `0..loaded` have been read (the last four of them are held).
    loaded: usize,
}

impl<'v> Grid<'v> {
    fn new(volume: &'v Volume) -> Grid<'v> {
        let [nx, ny, nz] = volume.dims.map(|d| d as usize);
        Grid { volume, nx, ny, nz, slices: Default::default(), loaded: 0 }
    }

    /// Reads slices up to `z` (clamped to the volume).
    fn load_through(&mut self, z: usize) {
        let plane = self.nx * self.ny;
        let scaling = self.volume.scaling;
        while self.loaded <= z.min(self.nz - 1) {
            let slice = &mut self.slices[self.loaded % 4];
            slice.clear();
            let start = self.loaded * plane;
            self.volume.samples.for_each(start..start + plane, |s| slice.push(scaling.apply(s)));
            self.loaded += 1;
        }
    }

    fn value(&self, [i, j, z]: [usize; 3]) -> f32 {
        self.slices[z % 4][i + j * self.nx]
    }

    /// The gradient in index space at a voxel centre: central differences, one-sided at the
    /// border.
    fn gradient(&self, p: [usize; 3]) -> Vec3 {
        let n = [self.nx, self.ny, self.nz];
        Vec3::from_array(std::array::from_fn(|axis| {
            let (mut lo, mut hi) = (p, p);
            lo[axis] = p[axis].saturating_sub(1);
            hi[axis] = (p[axis] + 1).min(n[axis] - 1);
            (self.value(hi) - self.value(lo)) / (hi[axis] - lo[axis]) as f32
        }))
    }
}

/// The mesh being built, and the indices of the vertices already made on the edges of the
/// current layer of cells.
struct Builder {
    level: f32,
    transform: Transform,
    nx: usize,
    /// Vertices on x edges in the layer's lower and upper slice, by the edge's lower voxel.
    x_edges: [Vec<u32>; 2],
    /// Vertices on y edges in the layer's lower and upper slice.
    y_edges: [Vec<u32>; 2],
    /// Vertices on z edges between the layer's slices.
    z_edges: Vec<u32>,
    positions: Vec<[f32; 3]>,
    /// Patient-space negated gradients, not yet normalised.
    normals: Vec<[f32; 3]>,
    indices: Vec<u32>,
}

impl Builder {
    fn new(grid: &Grid, level: f32, transform: Transform) -> Builder {
        let plane = grid.nx * grid.ny;
        Builder {
            level,
            transform,
            nx: grid.nx,
            x_edges: [vec![NONE; plane], vec![NONE; plane]],
            y_edges: [vec![NONE; plane], vec![NONE; plane]],
            z_edges: vec![NONE; plane],
            positions: Vec::new(),
            normals: Vec::new(),
            indices: Vec::new(),
        }
    }

    /// Moves the caches up one layer: the upper slice's edges become the lower's.
    fn next_layer(&mut self) {
        for edges in [&mut self.x_edges, &mut self.y_edges] {
            edges.swap(0, 1);
            edges[1].fill(NONE);
        }
        self.z_edges.fill(NONE);
    }

    /// The vertex on edge `edge` (0..12) of the cell whose lowest corner is voxel `cell`, made if
    /// the edge has none yet.
    fn vertex(&mut self, grid: &Grid, cell: [usize; 3], edge: usize) -> Result<u32, MeshError> {
        let (axis, u, w) = (edge / 4, edge & 1, edge >> 1 & 1);
        let [i, j, _] = cell;
        let slot = match axis {
            0 => &mut self.x_edges[w][i + (j + u) * self.nx],
            1 => &mut self.y_edges[w][i + u + j * self.nx],
            _ => &mut self.z_edges[i + u + (j + w) * self.nx],
        };
        if *slot != NONE {
            return Ok(*slot);
        }
        let index = u32::try_from(self.positions.len()).ok().filter(|&n| n != NONE).ok_or_else(|| {
            MeshError::shape(
                SOURCE,
                "the surface has more vertices than 32-bit indices can address: lower Limits::max_triangles",
            )
        })?;
        *slot = index;

        let (low, _) = edge_corners(edge);
        let a = std::array::from_fn(|n| cell[n] + (low >> n & 1));
        let mut b = a;
        b[axis] += 1;
        let (va, vb) = (grid.value(a), grid.value(b));
        let t = (self.level - va) / (vb - va);
        let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.5 };
        let mut p = Vec3::from_array(a.map(|c| c as f32));
        p[axis] += t;
        let gradient = grid.gradient(a).lerp(grid.gradient(b), t);
        self.positions.push(self.transform.grid_to_world.transform_point3(p).into());
        self.normals.push((-(self.transform.gradient * gradient)).into());
        Ok(index)
    }

    /// Unit normals: the gradient's where it has a direction, the faces' elsewhere.
    fn finish(self) -> Mesh {
        let Builder { positions, mut normals, indices, .. } = self;
        let mut faces = None;
        for (n, normal) in normals.iter_mut().enumerate() {
            match Vec3::from(*normal).try_normalize() {
                Some(unit) => *normal = unit.into(),
                None => {
                    let faces = faces.get_or_insert_with(|| normals::area_weighted(&positions, &indices));
                    *normal = faces[n];
                }
            }
        }
        Mesh { positions, normals, indices }
    }
}

/// Marches every cell, a layer (between two slices) at a time.
fn march(mut grid: Grid, builder: &mut Builder, limits: &Limits) -> Result<(), MeshError> {
    let cases = cases();
    let (nx, ny, nz) = (grid.nx, grid.ny, grid.nz);
    for k in 0..nz - 1 {
        grid.load_through(k + 2);
        if k > 0 {
            builder.next_layer();
        }
        let (lower, upper) = (&grid.slices[k % 4], &grid.slices[(k + 1) % 4]);
        let level = builder.level;
        let inside = |slice: &[f32], at: usize| u8::from(slice[at] >= level);
        for j in 0..ny - 1 {
            let (row0, row1) = (j * nx, (j + 1) * nx);
            for i in 0..nx - 1 {
                let config = inside(lower, row0 + i)
                    | inside(lower, row0 + i + 1) << 1
                    | inside(lower, row1 + i) << 2
                    | inside(lower, row1 + i + 1) << 3
                    | inside(upper, row0 + i) << 4
                    | inside(upper, row0 + i + 1) << 5
                    | inside(upper, row1 + i) << 6
                    | inside(upper, row1 + i + 1) << 7;
                let case = &cases[usize::from(config)];
                if case.len == 0 {
                    continue;
                }
                if builder.indices.len() / 3 + usize::from(case.len) > limits.max_triangles {
                    let message = format!(
                        "the surface at level {} has more than {} triangles, the limit: raise \
                         Limits::max_triangles, or crop or downsample the volume",
                        builder.level, limits.max_triangles
                    );
                    return Err(MeshError::shape(SOURCE, message));
                }
                let mut made = [NONE; 12];
                for triangle in &case.triangles[..usize::from(case.len)] {
                    let mut ids = [0; 3];
                    for (id, &edge) in ids.iter_mut().zip(triangle) {
                        let edge = usize::from(edge);
                        if made[edge] == NONE {
                            made[edge] = builder.vertex(&grid, [i, j, k], edge)?;
                        }
                        *id = made[edge];
                    }
                    if builder.transform.mirrors {
                        ids.swap(1, 2);
                    }
                    builder.indices.extend(ids);
                }
            }
        }
    }
    Ok(())
}

/// One of the 256 cell configurations (bit `c` set when corner `c` is inside): its triangles, as
/// cell edges, counter-clockwise seen from outside in index space.
#[derive(Clone, Copy)]
struct Case {
    len: u8,
    triangles: [[u8; 3]; MAX_CASE_TRIANGLES],
}

// Corner `c` of a cell is at offset (c & 1, c >> 1 & 1, c >> 2 & 1). Edge `4 * axis + u + 2 * w`
// runs along `axis`, at offset `u` along the first of the other two axes and `w` along the second.

/// The table, generated on first use.
fn cases() -> &'static [Case; 256] {
    static CASES: OnceLock<Box<[Case; 256]>> = OnceLock::new();
    CASES.get_or_init(|| Box::new(std::array::from_fn(|config| case(config as u8))))
}

/// The two axes other than `axis`, in order.
fn other_axes(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// An edge's corners, the lower first.
fn edge_corners(edge: usize) -> (usize, usize) {
    let (axis, u, w) = (edge / 4, edge & 1, edge >> 1 & 1);
    let (first, second) = other_axes(axis);
    let low = u << first | w << second;
    (low, low | 1 << axis)
}

/// The edge between two corners that differ along one axis.
fn edge_between(a: usize, b: usize) -> usize {
    let axis = (a ^ b).trailing_zeros() as usize;
    let (first, second) = other_axes(axis);
    4 * axis + (a >> first & 1) + 2 * (a >> second & 1)
}

fn corner_position(corner: usize) -> Vec3 {
    Vec3::new((corner & 1) as f32, (corner >> 1 & 1) as f32, (corner >> 2 & 1) as f32)
}

/// The two cell faces an edge lies on, as bits `2 * axis + side`.
fn edge_faces(edge: usize) -> u8 {
    let (axis, u, w) = (edge / 4, edge & 1, edge >> 1 & 1);
    let (first, second) = other_axes(axis);
    1 << (2 * first + u) | 1 << (2 * second + w)
}

fn edge_midpoint(edge: usize) -> Vec3 {
    let (a, b) = edge_corners(edge);
    (corner_position(a) + corner_position(b)) / 2.0
}

/// The triangles of one configuration: the crossings on each face joined so that the inside
/// corners lie on the left seen from outside the cell (two diagonal inside corners each cut off
/// alone), the resulting loops triangulated.
fn case(config: u8) -> Case {
    let inside = |corner: usize| config >> corner & 1 == 1;
    let mut next: [Option<usize>; 12] = [None; 12];
    for axis in 0..3 {
        let (first, second) = other_axes(axis);
        for side in 0..2 {
            let base = side << axis;
            let ring = [base, base | 1 << first, base | 1 << first | 1 << second, base | 1 << second];
            // Face edge `n` joins ring[n] and ring[n + 1].
            let edges: [usize; 4] = std::array::from_fn(|n| edge_between(ring[n], ring[(n + 1) % 4]));
            let crossing: Vec<usize> = (0..4).filter(|&n| inside(ring[n]) != inside(ring[(n + 1) % 4])).collect();
            let segments: Vec<(usize, usize)> = match crossing[..] {
                [] => Vec::new(),
                [a, b] => vec![(edges[a], edges[b])],
                _ => (0..4).filter(|&n| inside(ring[n])).map(|n| (edges[(n + 3) % 4], edges[n])).collect(),
            };
            let mut outward = Vec3::ZERO;
            outward[axis] = if side == 1 { 1.0 } else { -1.0 };
            for (e1, e2) in segments {
                let (c0, c1) = edge_corners(e1);
                let corner = corner_position(if inside(c0) { c0 } else { c1 });
                let (p, q) = (edge_midpoint(e1), edge_midpoint(e2));
                let (from, to) = if (q - p).cross(corner - p).dot(outward) > 0.0 { (e1, e2) } else { (e2, e1) };
                debug_assert!(next[from].is_none(), "config {config:#010b}: edge {from} leaves twice");
                next[from] = Some(to);
            }
        }
    }
    let mut case = Case { len: 0, triangles: [[0; 3]; MAX_CASE_TRIANGLES] };
    let mut visited = [false; 12];
    for start in 0..12 {
        if next[start].is_none() || visited[start] {
            continue;
        }
        let mut ring = Vec::new();
        let mut edge = start;
        loop {
            visited[edge] = true;
            ring.push(edge as u8);
            edge = next[edge].unwrap_or_else(|| panic!("config {config:#010b}: the loop through edge {edge} is open"));
            if edge == start {
                break;
            }
        }
        triangulate(&ring, &mut case);
    }
    case
}

/// Adds the triangles of one loop (edges in order, counter-clockwise seen from the inside
/// corners) to `case`: the triangulation of least total diagonal length among those whose
/// diagonals cross the cell. A diagonal between two edges of one face (possible only on an
/// ambiguous face that the loop crosses twice) would lie in that face, where the neighbouring
/// cell may draw the same one, making the surface pinch there.
fn triangulate(ring: &[u8], case: &mut Case) {
    let n = ring.len();
    let edge = |i: usize| usize::from(ring[i]);
    let weight = |i: usize, j: usize| {
        if j == i + 1 || (i == 0 && j == n - 1) {
            0.0
        } else if edge_faces(edge(i)) & edge_faces(edge(j)) != 0 {
            f32::INFINITY
        } else {
            edge_midpoint(edge(i)).distance(edge_midpoint(edge(j)))
        }
    };
    // cost[i][j]: the least diagonal length triangulating the sub-polygon i..=j; split: its apex.
    let mut cost = [[0.0f32; 12]; 12];
    let mut split = [[0usize; 12]; 12];
    for span in 2..n {
        for i in 0..n - span {
            let j = i + span;
            cost[i][j] = f32::INFINITY;
            for k in i + 1..j {
                let c = cost[i][k] + cost[k][j] + weight(i, k) + weight(k, j);
                if c < cost[i][j] {
                    (cost[i][j], split[i][j]) = (c, k);
                }
            }
        }
    }
    assert!(cost[0][n - 1].is_finite(), "loop {ring:?} has no triangulation through the cell");
    let mut pending = vec![(0, n - 1)];
    while let Some((i, j)) = pending.pop() {
        if j - i < 2 {
            continue;
        }
        let k = split[i][j];
        // Reversed: counter-clockwise seen from outside.
        case.triangles[usize::from(case.len)] = [ring[i], ring[j], ring[k]];
        case.len += 1;
        pending.extend([(i, k), (k, j)]);
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;
    use std::time::Instant;

    use glam::{Mat4, Quat, Vec3};

    use super::{MAX_CASE_TRIANGLES, cases, extract};
    use crate::mesh::{Limits, Mesh};
    use crate::volume::{Samples, Scaling, Volume};

    /// A volume whose value at each voxel is `f` of its patient-space centre.
    fn field(dims: [u32; 3], grid_to_world: Mat4, f: impl Fn(Vec3) -> f32) -> Volume {
        let mut data = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    data.push(f(grid_to_world.transform_point3(Vec3::new(i as f32, j as f32, k as f32))));
                }
            }
        }
        Volume::new(dims, grid_to_world, data)
    }

    /// Positive inside a ball of `radius` about `centre`: the surface at level 0 is its sphere.
    fn ball(dims: [u32; 3], grid_to_world: Mat4, centre: Vec3, radius: f32) -> Volume {
        field(dims, grid_to_world, |p| radius - p.distance(centre))
    }

    fn extract_ok(volume: &Volume, level: f32) -> Mesh {
        extract(volume, level, &Limits::default()).unwrap_or_else(|e| panic!("{e}"))
    }

    fn extract_err(volume: &Volume, level: f32, limits: &Limits) -> String {
        match extract(volume, level, limits) {
            Ok(mesh) => panic!("extracted {} triangles, expected an error", mesh.triangle_count()),
            Err(e) => e.to_string(),
        }
    }

    /// The enclosed volume by the divergence theorem: positive when the winding is outward.
    fn signed_volume(mesh: &Mesh) -> f64 {
        let p = |i: u32| Vec3::from(mesh.positions[i as usize]).as_dvec3();
        mesh.indices.chunks_exact(3).map(|t| p(t[0]).dot(p(t[1]).cross(p(t[2]))) / 6.0).sum()
    }

    /// Closed with consistent winding: every directed edge once, and its reverse once.
    fn assert_closed(mesh: &Mesh) {
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        for t in mesh.indices.chunks_exact(3) {
            assert!(t[0] != t[1] && t[1] != t[2] && t[2] != t[0], "triangle {t:?} repeats a vertex");
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *directed.entry((a, b)).or_default() += 1;
            }
        }
        for (&(a, b), &count) in &directed {
            assert_eq!(count, 1, "edge {a}->{b} is in {count} triangles the same way round");
            assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}->{b} has no triangle on its other side");
        }
        let used = mesh.indices.iter().fold(vec![false; mesh.positions.len()], |mut used, &i| {
            used[i as usize] = true;
            used
        });
        assert!(used.iter().all(|&u| u), "a vertex belongs to no triangle");
    }

    /// Every normal unit length, pointing away from `centre`, as does every triangle of some area.
    fn assert_outward(mesh: &Mesh, centre: Vec3) {
        assert_eq!(mesh.normals.len(), mesh.positions.len());
        for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
            let (p, n) = (Vec3::from(*p), Vec3::from(*n));
            assert!((n.length() - 1.0).abs() < 1e-4, "normal {n} is not unit length");
            assert!(n.dot((p - centre).normalize()) > 0.9, "normal {n} at {p} does not point outwards");
        }
        for t in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(mesh.positions[i as usize]));
            let face = (b - a).cross(c - a);
            if face.length() > 1e-6 {
                assert!(face.dot((a + b + c) / 3.0 - centre) > 0.0, "triangle {t:?} faces inwards");
            }
        }
    }

    /// The sphere of `radius` about `centre`: vertices within `tolerance`, volume within 3%,
    /// closed, facing outwards.
    fn assert_sphere(mesh: &Mesh, centre: Vec3, radius: f32, tolerance: f32) {
        let worst = mesh.positions.iter().map(|&p| (Vec3::from(p).distance(centre) - radius).abs()).fold(0.0, f32::max);
        assert!(worst < tolerance, "a vertex is {worst} mm off the sphere (tolerance {tolerance})");
        let expected = 4.0 / 3.0 * std::f64::consts::PI * f64::from(radius).powi(3);
        let volume = signed_volume(mesh);
        assert!((volume / expected - 1.0).abs() < 0.03, "volume {volume}, expected {expected}");
        assert_closed(mesh);
        assert_outward(mesh, centre);
    }

    #[test]
    fn table_covers_every_mixed_cell() {
        let cases = cases();
        assert_eq!(cases[0].len, 0);
        assert_eq!(cases[255].len, 0);
        let most = cases.iter().map(|c| usize::from(c.len)).max().unwrap_or(0);
        assert_eq!(most, MAX_CASE_TRIANGLES);
        assert!(cases[1..255].iter().all(|c| c.len > 0), "a mixed cell makes no triangles");
    }

    #[test]
    fn sphere_in_voxel_space() {
        let centre = Vec3::splat(15.3);
        let volume = ball([32, 32, 32], Mat4::IDENTITY, centre, 11.0);
        let mesh = extract_ok(&volume, 0.0);
        assert_sphere(&mesh, centre, 11.0, 0.5);
        // Shared vertices: a closed surface has about half as many vertices as triangles.
        assert!(mesh.positions.len() * 2 <= mesh.triangle_count() + 8);
    }

    #[test]
    fn distance_field_normals_point_towards_lower_values() {
        let centre = Vec3::splat(10.0);
        let volume = field([21, 21, 21], Mat4::IDENTITY, |p| p.distance(centre));
        let mesh = extract_ok(&volume, 7.0);
        // Inside (>= 7) is beyond the sphere: the normals point to its centre, the winding too.
        assert!(signed_volume(&mesh) < 0.0);
        assert_closed(&mesh);
        for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
            let (p, n) = (Vec3::from(*p), Vec3::from(*n));
            assert!(n.dot((centre - p).normalize()) > 0.9, "normal {n} at {p} does not point to the centre");
            assert!((p.distance(centre) - 7.0).abs() < 0.5);
        }
    }

    #[test]
    fn anisotropic_spacing() {
        let grid_to_world =
            Mat4::from_translation(Vec3::new(-20.0, 5.0, 30.0)) * Mat4::from_scale(Vec3::new(0.7, 1.0, 1.6));
        let centre = Vec3::new(-7.0, 19.0, 42.0);
        let volume = ball([40, 30, 18], grid_to_world, centre, 10.0);
        let mesh = extract_ok(&volume, 0.0);
        assert_sphere(&mesh, centre, 10.0, 0.5 * 0.7);
    }

    #[test]
    fn rotated_and_mirrored_grid() {
        let rotation = Quat::from_axis_angle(Vec3::new(1.0, 2.0, -0.5).normalize(), 0.8);
        let index_to_world = Mat4::from_scale_rotation_translation(Vec3::ONE, rotation, Vec3::new(12.0, -40.0, 7.0))
            * Mat4::from_scale(Vec3::new(1.2, -0.9, 1.1));
        assert!(index_to_world.determinant() < 0.0);
        let centre_index = Vec3::new(14.2, 13.7, 12.9);
        let centre = index_to_world.transform_point3(centre_index);
        let volume = ball([30, 30, 28], index_to_world, centre, 9.0);
        let mesh = extract_ok(&volume, 0.0);
        assert_sphere(&mesh, centre, 9.0, 0.5 * 0.9);

        // The same as extracting in index space and then moving the mesh.
        let in_index_space = Volume { grid_to_world: Mat4::IDENTITY, ..volume.clone() };
        let moved = extract_ok(&in_index_space, 0.0).transformed(index_to_world);
        assert_eq!(moved.indices, mesh.indices);
        for (a, b) in moved.positions.iter().zip(&mesh.positions) {
            assert!(Vec3::from(*a).distance(Vec3::from(*b)) < 1e-3);
        }
        for (a, b) in moved.normals.iter().zip(&mesh.normals) {
            assert!(Vec3::from(*a).dot(Vec3::from(*b)) > 0.9999);
        }
    }

    #[test]
    fn binary_mask_at_half() {
        let dims = [16, 16, 16];
        let mut data = vec![0u8; 16 * 16 * 16];
        for k in 4..12 {
            for j in 4..12 {
                for i in 4..12 {
                    data[i + 16 * (j + 16 * k)] = 1;
                }
            }
        }
        let volume = Volume::from_samples(dims, Mat4::IDENTITY, Samples::U8(data), Scaling::IDENTITY);
        let mesh = extract_ok(&volume, 0.5);
        assert_closed(&mesh);
        assert_eq!(mesh.bounds(), Some(([3.5; 3], [11.5; 3])));
        // An 8-voxel cube with its edges and corners bevelled.
        let volume = signed_volume(&mesh);
        assert!(volume > 0.9 * 512.0 && volume < 512.0, "volume {volume}");
        for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
            assert!(Vec3::from(*n).dot(Vec3::from(*p) - Vec3::splat(7.5)) > 0.0);
        }
    }

    #[test]
    fn stored_samples_are_scaled_to_data_units() {
        // Stored 0/1, data -1000/+1000: level 0 lies between them.
        let mut data = vec![0i16; 8 * 8 * 8];
        data[3 + 8 * (3 + 8 * 3)] = 1;
        let scaling = Scaling { slope: 2000.0, intercept: -1000.0 };
        let volume = Volume::from_samples([8, 8, 8], Mat4::IDENTITY, Samples::I16(data), scaling);
        let mesh = extract_ok(&volume, 0.0);
        assert_closed(&mesh);
        assert_eq!(mesh.triangle_count(), 8);
        assert_eq!(mesh.positions.len(), 6);
        assert_eq!(mesh.bounds(), Some(([2.5; 3], [3.5; 3])));
    }

    /// Every configuration of one cell, and random masks, make closed, outward surfaces.
    #[test]
    fn every_case_is_closed() {
        for config in 1..=255u32 {
            let mut data = vec![0.0f32; 64];
            for c in 0..8 {
                if config >> c & 1 == 1 {
                    data[(1 + (c & 1)) + 4 * ((1 + (c >> 1 & 1)) + 4 * (1 + (c >> 2 & 1)))] = 1.0;
                }
            }
            let mesh = extract_ok(&Volume::new([4, 4, 4], Mat4::IDENTITY, data), 0.5);
            assert_closed(&mesh);
            assert!(signed_volume(&mesh) > 0.0, "config {config:#010b}");
        }
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..500 {
            let n = 7;
            let data: Vec<f32> = (0..n * n * n)
                .map(|v| {
                    let (i, j, k) = (v % n, v / n % n, v / (n * n));
                    seed ^= seed << 13;
                    seed ^= seed >> 7;
                    seed ^= seed << 17;
                    let border = [i, j, k].iter().any(|&c| c == 0 || c == n - 1);
                    if border { 0.0 } else { (seed % 1000) as f32 / 1000.0 }
                })
                .collect();
            let volume = Volume::new([n as u32; 3], Mat4::IDENTITY, data);
            let mesh = extract_ok(&volume, 0.5);
            assert_closed(&mesh);
            assert!(signed_volume(&mesh) > 0.0);
        }
    }

    #[test]
    fn nan_samples_count_as_outside() {
        let centre = Vec3::splat(10.0);
        let mut volume = ball([21, 21, 21], Mat4::IDENTITY, centre, 7.0);
        let Samples::F32(data) = &mut volume.samples else { unreachable!() };
        data[10 + 21 * (10 + 21 * 10)] = f32::NAN;
        let mesh = extract_ok(&volume, 0.0);
        assert_closed(&mesh);
        assert!(mesh.positions.iter().flatten().chain(mesh.normals.iter().flatten()).all(|v| v.is_finite()));
        // A small cavity around the NaN, its normals pointing into it.
        let cavity: Vec<usize> =
            (0..mesh.positions.len()).filter(|&i| Vec3::from(mesh.positions[i]).distance(centre) < 1.0).collect();
        assert_eq!(cavity.len(), 6);
        for i in cavity {
            let (p, n) = (Vec3::from(mesh.positions[i]), Vec3::from(mesh.normals[i]));
            assert!(n.dot(centre - p) > 0.0, "normal {n} at {p} points out of the cavity");
        }
    }

    #[test]
    fn errors() {
        let limits = Limits::default();
        let volume = ball([8, 8, 8], Mat4::IDENTITY, Vec3::splat(3.5), 2.0);
        let [lo, hi] = volume.range;

        let message = extract_err(&volume, hi + 1.0, &limits);
        assert!(message.starts_with("isosurface: no surface at level"), "{message}");
        assert!(message.contains(&format!("the values lie in [{lo}, {hi}]")), "{message}");
        assert!(extract_err(&volume, lo - 1.0, &limits).contains("no surface at level"));
        assert!(extract_err(&volume, lo, &limits).contains("no surface at level"));
        assert!(extract(&volume, hi, &limits).is_ok());
        assert!(extract_err(&volume, f32::NAN, &limits).contains("not a number"));

        let message = extract_err(&volume, 0.0, &Limits { max_triangles: 10, ..limits });
        assert!(message.contains("more than 10 triangles") && message.contains("max_triangles"), "{message}");

        let flat = Volume::new([1, 4, 4], Mat4::IDENTITY, (0..16).map(|v| v as f32).collect());
        let message = extract_err(&flat, 7.5, &limits);
        assert!(message.contains("1×4×4") && message.contains("at least 2"), "{message}");

        let short = Volume { samples: Samples::F32(vec![0.0; 10]), ..volume.clone() };
        assert!(extract_err(&short, 0.0, &limits).contains("10 samples"));

        let singular = Volume { grid_to_world: Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)), ..volume };
        assert!(extract_err(&singular, 0.0, &limits).contains("singular"));
    }

    /// Run with `--ignored --nocapture` for the times.
    #[test]
    #[ignore = "timing"]
    fn timing() {
        for n in [128u32, 256] {
            let c = (n as f32 - 1.0) / 2.0;
            let volume = ball([n; 3], Mat4::IDENTITY, Vec3::splat(c), 0.4 * n as f32);
            let start = Instant::now();
            let mesh = extract_ok(&volume, 0.0);
            let elapsed = start.elapsed();
            eprintln!(
                "{n}^3 sphere: {} triangles, {} vertices in {elapsed:?}",
                mesh.triangle_count(),
                mesh.positions.len()
            );
            assert_sphere(&mesh, Vec3::splat(c), 0.4 * n as f32, 0.5);
        }
    }
}
