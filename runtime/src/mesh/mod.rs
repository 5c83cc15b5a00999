//! Triangle meshes in patient space (RAS millimetres), loaded from files or made from built-in
//! shapes, for drawing alongside volumes. CPU only: the renderer uploads [`Mesh`]'s arrays as they
//! are.
//!
//! File formats are parsed by maintained crates, never by hand: `tobj` (OBJ: polygons fanned,
//! relative indices, several objects), `stl_io` (ASCII and binary STL) and `ply-rs-bw` (the
//! maintained fork of `ply-rs`: ASCII and both binary PLY encodings, capped pre-allocation). This
//! module only reads the few header bytes needed to bound what a file claims (a binary STL's
//! triangle count, a PLY header's element counts) against its size before a crate allocates, and
//! then validates what the crate returns: finite coordinates, indices in range, a triangle limit.
//! Normals are taken from the file where it has finite ones for every vertex, and otherwise
//! computed area-weighted from the faces.

mod error;
pub(crate) mod isosurface;
mod normals;
mod obj;
mod ply;
pub mod shapes;
mod stl;
#[cfg(test)]
mod tests;
mod validate;

use std::fs::File;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use glam::Vec3;
#[cfg(test)]
use glam::{Mat3, Mat4};

pub use error::MeshError;

/// One indexed triangle mesh in patient space (RAS millimetres).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Unit normals, one per vertex (same length as `positions`): from the file when it has finite
    /// ones for every vertex, otherwise computed area-weighted from the faces.
    pub(crate) normals: Vec<[f32; 3]>,
    /// Triangles, three indices into `positions` each, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
}

impl Mesh {
    #[cfg(test)]
    /// The number of triangles.
    pub(crate) fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// The axis-aligned bounds `(min, max)` of the vertices; `None` when there are none.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        let first = Vec3::from(*self.positions.first()?);
        let (min, max) = self.positions.iter().fold((first, first), |(min, max), &p| {
            let p = Vec3::from(p);
            (min.min(p), max.max(p))
        });
        Some((min.into(), max.into()))
    }

    /// Whether the surface is closed and wound counter-clockwise seen from outside: every edge
    /// (between vertices welded by position) is run once in each direction by two triangles,
    /// and the enclosed volume is positive. A renderer may cull such a surface's back faces.
    pub(crate) fn is_closed_outward(&self) -> bool {
        let mut welded: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
        let ids: Vec<u32> = self
            .positions
            .iter()
            .map(|p| {
                let next = welded.len() as u32;
                *welded.entry(p.map(f32::to_bits)).or_insert(next)
            })
            .collect();
        let mut edges: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
        let mut volume = 0.0f64;
        for t in self.indices.chunks_exact(3) {
            let Some(c) = t.iter().map(|&i| ids.get(i as usize).copied()).collect::<Option<Vec<u32>>>() else {
                return false;
            };
            for (a, b) in [(c[0], c[1]), (c[1], c[2]), (c[2], c[0])] {
                *edges.entry((a, b)).or_default() += 1;
            }
            let [p, q, r] = [t[0], t[1], t[2]].map(|i| glam::DVec3::from(self.positions[i as usize].map(f64::from)));
            volume += p.dot(q.cross(r)) / 6.0;
        }
        !edges.is_empty() && volume > 0.0 && edges.iter().all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1))
    }

    #[cfg(test)]
    /// The mesh moved by the affine transform `m`: positions by `m`, normals by the inverse
    /// transpose of its linear part, renormalised. A mirroring `m` (negative determinant) flips
    /// the winding, so triangles stay counter-clockwise seen from outside. A singular `m` leaves
    /// normals undefined, so they are recomputed from the transformed faces.
    pub(crate) fn transformed(mut self, m: Mat4) -> Mesh {
        for p in &mut self.positions {
            *p = m.transform_point3(Vec3::from(*p)).into();
        }
        let linear = Mat3::from_mat4(m);
        let det = linear.determinant();
        if det.is_finite() && det != 0.0 {
            let normal_matrix = linear.inverse().transpose();
            for n in &mut self.normals {
                *n = normals::unit_or_default(normal_matrix * Vec3::from(*n)).into();
            }
        }
        if det < 0.0 {
            for triangle in self.indices.chunks_exact_mut(3) {
                triangle.swap(1, 2);
            }
        }
        if !(det.is_finite() && det != 0.0) {
            self.normals = normals::area_weighted(&self.positions, &self.indices);
        }
        self
    }
}

/// The file formats [`load`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum MeshFormat {
    /// Wavefront OBJ (`.obj`).
    Obj,
    /// STL, ASCII or binary (`.stl`).
    Stl,
    /// Stanford PLY, ASCII or binary (`.ply`).
    Ply,
}

impl MeshFormat {
    /// The format named by the file's extension (case-insensitive); `None` for any other.
    pub(crate) fn from_path(path: &Path) -> Option<MeshFormat> {
        let extension = path.extension()?.to_str()?.to_ascii_lowercase();
        match extension.as_str() {
            "obj" => Some(MeshFormat::Obj),
            "stl" => Some(MeshFormat::Stl),
            "ply" => Some(MeshFormat::Ply),
            _ => None,
        }
    }

    fn name(self) -> &'static str {
        match self {
            MeshFormat::Obj => "OBJ",
            MeshFormat::Stl => "STL",
            MeshFormat::Ply => "PLY",
        }
    }
}

/// Bounds on what a file may make [`load`] read and allocate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Limits {
    /// The most triangles a mesh may have (after polygons are fanned). Default 20 000 000.
    pub max_triangles: usize,
    /// The largest file read, checked before reading. Default 2 GiB.
    pub max_file_bytes: u64,
}

impl Default for Limits {
    fn default() -> Limits {
        Limits { max_triangles: 20_000_000, max_file_bytes: 2 << 30 }
    }
}

/// Axis convention of a file's coordinates: RAS (as written) or LPS (3D Slicer's and ITK's
/// files: x and y negated on load).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) enum Coordinates {
    /// Right, anterior, superior: the file's coordinates are used as written.
    #[default]
    Ras,
    /// Left, posterior, superior: x and y are negated (a rotation, so the winding is kept).
    Lps,
}

#[cfg(test)]
/// Loads a mesh file whose coordinates are RAS millimetres; the format is chosen by extension.
pub(crate) fn load(path: &Path, limits: &Limits) -> Result<Mesh, MeshError> {
    load_with(path, Coordinates::Ras, limits)
}

/// Loads a mesh file whose coordinates follow `coordinates`, into RAS millimetres.
pub(crate) fn load_with(path: &Path, coordinates: Coordinates, limits: &Limits) -> Result<Mesh, MeshError> {
    let format = MeshFormat::from_path(path)
        .ok_or_else(|| MeshError::file(path, "unknown mesh format: the file name must end in .obj, .stl or .ply"))?;
    let size = checked_size(path, limits)?;
    let file = File::open(path).map_err(|e| MeshError::file(path, format!("cannot be opened: {e}")))?;
    let raw = parse_guarded(format, path, file, size, limits)?;
    let mut mesh = validate::finish(path, raw, limits)?;
    if coordinates == Coordinates::Lps {
        lps_to_ras(&mut mesh);
    }
    Ok(mesh)
}

/// The file's size, refusing what is missing, not a file, empty or over the limit.
fn checked_size(path: &Path, limits: &Limits) -> Result<u64, MeshError> {
    let metadata =
        std::fs::metadata(path).map_err(|e| MeshError::file(path, format!("cannot be read: {e}: check the path")))?;
    if metadata.is_dir() {
        return Err(MeshError::file(path, "is a directory, not a mesh file"));
    }
    let size = metadata.len();
    if size == 0 {
        return Err(MeshError::file(path, "is empty: it has no triangles"));
    }
    if size > limits.max_file_bytes {
        let message = format!(
            "is {}, more than the limit of {}: raise Limits::max_file_bytes or simplify the mesh",
            error::bytes(size.into()),
            error::bytes(limits.max_file_bytes.into())
        );
        return Err(MeshError::file(path, message));
    }
    Ok(size)
}

/// Runs the format's reader; a panic inside a parser crate becomes an error, not a crash.
fn parse_guarded(
    format: MeshFormat,
    path: &Path,
    file: File,
    size: u64,
    limits: &Limits,
) -> Result<validate::RawMesh, MeshError> {
    let parse = AssertUnwindSafe(|| match format {
        MeshFormat::Obj => obj::read(path, file, limits),
        MeshFormat::Stl => stl::read(path, file, size, limits),
        MeshFormat::Ply => ply::read(path, file, size, limits),
    });
    catch_unwind(parse).unwrap_or_else(|_| {
        let message = format!("the {} reader failed unexpectedly on this file: it is malformed", format.name());
        Err(MeshError::file(path, message))
    })
}

/// LPS to RAS: x and y negated. A rotation by half a turn about z, so the winding is unchanged.
fn lps_to_ras(mesh: &mut Mesh) {
    for v in mesh.positions.iter_mut().chain(mesh.normals.iter_mut()) {
        v[0] = -v[0];
        v[1] = -v[1];
    }
}
