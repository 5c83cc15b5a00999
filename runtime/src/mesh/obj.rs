//! Wavefront OBJ through `tobj`: polygons fanned into triangles, every object merged into one
//! mesh, materials never opened.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use tobj::{LoadError, LoadOptions};

use super::validate::{RawMesh, check_triangle_count};
use super::{Limits, MeshError};

/// Reads an OBJ file: positions, faces and, where every vertex has one, normals.
pub(crate) fn read(path: &Path, file: File, limits: &Limits) -> Result<RawMesh, MeshError> {
    #[allow(clippy::needless_update, reason = "tobj's `merging` and `reordering` features add fields")]
    let options = LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..LoadOptions::default()
    };
    let no_materials = |_: &Path| Err(LoadError::OpenFileFailed);
    let (models, _) =
        tobj::load_obj_buf(&mut BufReader::new(file), &options, no_materials).map_err(|e| parse_error(path, e))?;
    let triangles = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    check_triangle_count(path, triangles, limits)?;
    merge(path, models.iter().map(|m| &m.mesh))
}

fn parse_error(path: &Path, e: LoadError) -> MeshError {
    let message = match e {
        LoadError::FaceVertexOutOfBounds => format!(
            "a face refers to a vertex that does not exist ({e}): the index is out of range, \
             or the file is truncated"
        ),
        LoadError::ReadError => {
            format!("the OBJ could not be read as text ({e}): the file is not UTF-8 text or not an OBJ file")
        }
        _ => format!("the OBJ could not be parsed ({e}): the file is malformed or truncated"),
    };
    MeshError::file(path, message)
}

/// One mesh of all the objects, each object's indices moved past the vertices before it.
fn merge<'a>(path: &Path, meshes: impl Iterator<Item = &'a tobj::Mesh>) -> Result<RawMesh, MeshError> {
    let mut raw = RawMesh { normals: Some(Vec::new()), ..RawMesh::default() };
    for mesh in meshes {
        let offset = u32::try_from(raw.positions.len())
            .map_err(|_| MeshError::file(path, "has more than 4 294 967 295 vertices: decimate the mesh"))?;
        raw.indices.extend(mesh.indices.iter().map(|&i| i.saturating_add(offset)));
        let positions: Vec<[f32; 3]> = triples(&mesh.positions);
        let normals = triples(&mesh.normals);
        if normals.len() != positions.len() {
            raw.normals = None;
        }
        if let Some(all) = &mut raw.normals {
            all.extend(normals);
        }
        raw.positions.extend(positions);
    }
    Ok(raw)
}

fn triples(flat: &[f32]) -> Vec<[f32; 3]> {
    flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}
