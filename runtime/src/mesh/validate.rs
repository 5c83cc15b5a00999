//! What every reader hands over, and the checks that turn it into a [`Mesh`].

use std::path::Path;

use super::{Limits, Mesh, MeshError, normals};

/// A parsed file before validation: triangles (already fanned), and the file's normals if it has
/// some for every vertex.
#[derive(Debug, Default)]
pub(crate) struct RawMesh {
    pub positions: Vec<[f32; 3]>,
    pub normals: Option<Vec<[f32; 3]>>,
    pub indices: Vec<u32>,
}

/// Checks the triangle count, coordinates and indices, then settles the normals.
pub(crate) fn finish(path: &Path, raw: RawMesh, limits: &Limits) -> Result<Mesh, MeshError> {
    check_triangle_count(path, raw.indices.len() / 3, limits)?;
    check_finite(path, &raw.positions)?;
    check_indices(path, &raw.indices, raw.positions.len())?;
    let normals = match raw.normals {
        Some(normals) if normals::usable(&normals, raw.positions.len()) => normals::normalised(normals),
        _ => normals::area_weighted(&raw.positions, &raw.indices),
    };
    Ok(Mesh { positions: raw.positions, normals, indices: raw.indices })
}

/// Refuses a mesh without triangles or with more than the limit.
pub(crate) fn check_triangle_count(path: &Path, triangles: usize, limits: &Limits) -> Result<(), MeshError> {
    if triangles == 0 {
        return Err(MeshError::file(path, "has no triangles: it holds no faces to draw (points or lines only?)"));
    }
    if triangles > limits.max_triangles {
        let message = format!(
            "has {triangles} triangles, more than the limit of {}: decimate the mesh or raise Limits::max_triangles",
            limits.max_triangles
        );
        return Err(MeshError::file(path, message));
    }
    Ok(())
}

/// Refuses the first vertex with a NaN or infinite coordinate.
fn check_finite(path: &Path, positions: &[[f32; 3]]) -> Result<(), MeshError> {
    let Some((index, p)) = positions.iter().enumerate().find(|(_, p)| !p.iter().all(|c| c.is_finite())) else {
        return Ok(());
    };
    let message = format!(
        "vertex {index} has coordinates ({}, {}, {}), which are not all finite numbers: the file is corrupt",
        p[0], p[1], p[2]
    );
    Err(MeshError::file(path, message))
}

/// Refuses the first triangle with an index past the vertices.
fn check_indices(path: &Path, indices: &[u32], vertex_count: usize) -> Result<(), MeshError> {
    let bad = indices.iter().position(|&i| i as usize >= vertex_count);
    let Some(at) = bad else {
        return Ok(());
    };
    let message = format!(
        "triangle {} refers to vertex {}, but the file has only {vertex_count} vertices: the index is out of range",
        at / 3,
        indices[at]
    );
    Err(MeshError::file(path, message))
}
