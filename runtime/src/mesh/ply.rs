//! Stanford PLY through `ply-rs-bw`, after bounding the header's element counts by the file size.
//!
//! The crate parses the header; before it reads the body, the least number of bytes the claimed
//! elements need (binary: the sizes of their scalars and list counts; ASCII: two characters per
//! property) is compared with what follows the header, so a header claiming a million faces in a
//! file of a kilobyte is refused before anything is allocated for them. Vertices and faces are
//! read into small structs of this module, other elements are skipped.

use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::path::Path;

use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Encoding, Header, Property, PropertyAccess, PropertyAccessResult};
use ply_rs_bw::ply::{PropertyType, ScalarType};

use super::validate::{RawMesh, check_triangle_count};
use super::{Limits, MeshError, error};

/// How far into the file the header must end.
const HEADER_LIMIT: u64 = 64 * 1024;
/// The names a face's list of vertex indices goes by.
const FACE_LISTS: [&str; 2] = ["vertex_indices", "vertex_index"];

/// Reads an ASCII or binary PLY file of `size` bytes.
pub(crate) fn read(path: &Path, mut file: File, size: u64, limits: &Limits) -> Result<RawMesh, MeshError> {
    check_header_present(path, &mut file)?;
    file.rewind().map_err(|e| read_error(path, &e))?;
    let mut reader = Reader::new(BufReader::new(file));
    let header = Parser::<Skip>::new().read_header(&mut reader).map_err(|e| parse_error(path, "header", &e))?;
    let header_len = reader.get_mut().stream_position().map_err(|e| read_error(path, &e))?;
    check_claims(path, &header, size.saturating_sub(header_len))?;
    let vertex = check_elements(path, &header)?;
    let has_normals = ["nx", "ny", "nz"].iter().all(|n| vertex.properties.contains_key(*n));
    let (vertices, faces) = read_body(path, &mut reader, &header)?;
    triangulate(path, vertices, &faces, has_normals, limits)
}

/// Refuses a file that does not begin with `ply` or whose header does not end early on.
fn check_header_present(path: &Path, file: &mut File) -> Result<(), MeshError> {
    let mut head = Vec::new();
    file.take(HEADER_LIMIT).read_to_end(&mut head).map_err(|e| read_error(path, &e))?;
    if !head.starts_with(b"ply") {
        return Err(MeshError::file(path, "does not begin with \"ply\": it is not a PLY file"));
    }
    let ends = head.windows(11).any(|w| w == b"\nend_header");
    if !ends {
        let message = format!(
            "has no end_header line in its first {}: the file is truncated or not a PLY file",
            error::bytes(HEADER_LIMIT.into())
        );
        return Err(MeshError::file(path, message));
    }
    Ok(())
}

/// Refuses a header whose elements need more bytes than follow it.
fn check_claims(path: &Path, header: &Header, body: u64) -> Result<(), MeshError> {
    let ascii = header.encoding == Encoding::Ascii;
    let needed: u128 = header.elements.values().map(|e| e.count as u128 * least_bytes(e, ascii)).sum();
    // The last line of an ASCII body may lack its newline.
    let needed = if ascii { needed.saturating_sub(1) } else { needed };
    if needed <= u128::from(body) {
        return Ok(());
    }
    let counts: Vec<String> = header.elements.values().map(|e| format!("{} {}", e.count, e.name)).collect();
    let message = format!(
        "the PLY header claims {} elements (at least {}) but only {body} bytes follow the header: \
         the file is truncated or its header is wrong",
        counts.join(" and "),
        error::bytes(needed)
    );
    Err(MeshError::file(path, message))
}

/// The fewest bytes one element can take: binary, its scalars and list counts (lists may be
/// empty); ASCII, a digit and a separator per property.
fn least_bytes(element: &ElementDef, ascii: bool) -> u128 {
    let property_bytes = |p: &PropertyType| match p {
        _ if ascii => 2,
        PropertyType::Scalar(t) | PropertyType::List(t, _) => scalar_bytes(t),
    };
    element.properties.values().map(|p| property_bytes(&p.data_type)).sum()
}

fn scalar_bytes(t: &ScalarType) -> u128 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// The vertex element (with x, y, z), once the face element is known to have a list of indices.
fn check_elements<'h>(path: &Path, header: &'h Header) -> Result<&'h ElementDef, MeshError> {
    let vertex = header
        .elements
        .get("vertex")
        .filter(|v| ["x", "y", "z"].iter().all(|c| v.properties.contains_key(*c)))
        .ok_or_else(|| MeshError::file(path, "has no vertex element with x, y and z properties"))?;
    let face = header.elements.get("face").filter(|f| f.count > 0).ok_or_else(|| {
        MeshError::file(path, "has no triangles: its header declares no faces (a point cloud is not a mesh)")
    })?;
    if !FACE_LISTS.iter().any(|name| face.properties.contains_key(*name)) {
        return Err(MeshError::file(path, "its face element has no vertex_indices list: it has no triangles"));
    }
    Ok(vertex)
}

type Body = (Vec<PlyVertex>, Vec<PlyFace>);

/// Reads every element in order, keeping vertices and faces.
fn read_body(path: &Path, reader: &mut Reader<BufReader<File>>, header: &Header) -> Result<Body, MeshError> {
    let (mut vertices, mut faces) = (Vec::new(), Vec::new());
    for element in header.elements.values() {
        let what = element.name.as_str();
        let error = |e| parse_error(path, what, &e);
        match what {
            "vertex" => vertices = Parser::new().read_payload_for_element(reader, element, header).map_err(error)?,
            "face" => faces = Parser::new().read_payload_for_element(reader, element, header).map_err(error)?,
            _ => drop(Parser::<Skip>::new().read_payload_for_element(reader, element, header).map_err(error)?),
        }
    }
    Ok((vertices, faces))
}

/// Fans the faces into triangles, checking each face's indices first.
fn triangulate(
    path: &Path,
    vertices: Vec<PlyVertex>,
    faces: &[PlyFace],
    has_normals: bool,
    limits: &Limits,
) -> Result<RawMesh, MeshError> {
    let vertex_count = u32::try_from(vertices.len())
        .map_err(|_| MeshError::file(path, "has more than 4 294 967 295 vertices: decimate the mesh"))?;
    for (number, face) in faces.iter().enumerate() {
        face.check_corners(path, number, vertex_count)?;
    }
    let triangles = faces.iter().map(|f| f.corners().len().saturating_sub(2)).sum();
    check_triangle_count(path, triangles, limits)?;
    let mut indices = Vec::with_capacity(triangles * 3);
    for corners in faces.iter().map(PlyFace::corners) {
        for pair in corners.get(1..).unwrap_or_default().windows(2) {
            indices.extend([corners[0], pair[0], pair[1]]);
        }
    }
    let normals = has_normals.then(|| vertices.iter().map(|v| v.normal).collect());
    Ok(RawMesh { positions: vertices.into_iter().map(|v| v.position).collect(), normals, indices })
}

fn read_error(path: &Path, e: &std::io::Error) -> MeshError {
    MeshError::file(path, format!("cannot be read: {e}"))
}

fn parse_error(path: &Path, what: &str, e: &ply_rs_bw::parser::ParseError) -> MeshError {
    let message = e.to_string().replace(['\n', '\t'], " ");
    let message = format!("the PLY {what} could not be read ({message}): the file is truncated or malformed");
    MeshError::file(path, message)
}

/// A vertex as read: position and, if the file has them, normal.
struct PlyVertex {
    position: [f32; 3],
    normal: [f32; 3],
}

impl PropertyAccess for PlyVertex {
    fn new() -> PlyVertex {
        PlyVertex { position: [0.0; 3], normal: [0.0; 3] }
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let slot = match name {
            "x" => &mut self.position[0],
            "y" => &mut self.position[1],
            "z" => &mut self.position[2],
            "nx" => &mut self.normal[0],
            "ny" => &mut self.normal[1],
            "nz" => &mut self.normal[2],
            _ => return PropertyAccessResult::Ignored,
        };
        match property.to_f32_lossy() {
            Some(value) => {
                *slot = value;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
}

/// A face as read: its corners, compact for the common triangle.
enum PlyFace {
    Triangle([u32; 3]),
    Other(Box<[u32]>),
    Negative(i64),
}

impl PlyFace {
    fn from_list<T: Copy + Into<i64>>(values: &[T]) -> PlyFace {
        let wide = values.iter().map(|&v| v.into());
        if let Some(negative) = wide.clone().find(|&v| v < 0) {
            return PlyFace::Negative(negative);
        }
        // Every list type is at most 32 bits wide, so a non-negative value fits in u32.
        let corners: Box<[u32]> = wide.map(|v| v as u32).collect();
        match *corners {
            [a, b, c] => PlyFace::Triangle([a, b, c]),
            _ => PlyFace::Other(corners),
        }
    }

    fn corners(&self) -> &[u32] {
        match self {
            PlyFace::Triangle(corners) => corners,
            PlyFace::Other(corners) => corners,
            PlyFace::Negative(_) => &[],
        }
    }

    /// Refuses a negative index or one past the vertices.
    fn check_corners(&self, path: &Path, number: usize, vertex_count: u32) -> Result<(), MeshError> {
        if let PlyFace::Negative(index) = self {
            let message = format!("face {number} has the vertex index {index}: indices must not be negative");
            return Err(MeshError::file(path, message));
        }
        if let Some(&index) = self.corners().iter().find(|&&i| i >= vertex_count) {
            let message = format!(
                "face {number} refers to vertex {index}, but the file has only {vertex_count} vertices: \
                 the index is out of range"
            );
            return Err(MeshError::file(path, message));
        }
        Ok(())
    }
}

impl PropertyAccess for PlyFace {
    fn new() -> PlyFace {
        PlyFace::Other(Box::default())
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if !FACE_LISTS.contains(&name) {
            return PropertyAccessResult::Ignored;
        }
        *self = match property {
            Property::ListChar(v) => PlyFace::from_list(&v),
            Property::ListUChar(v) => PlyFace::from_list(&v),
            Property::ListShort(v) => PlyFace::from_list(&v),
            Property::ListUShort(v) => PlyFace::from_list(&v),
            Property::ListInt(v) => PlyFace::from_list(&v),
            Property::ListUInt(v) => PlyFace::from_list(&v),
            _ => return PropertyAccessResult::UnsupportedType,
        };
        PropertyAccessResult::Set
    }
}

/// An element that is read past and dropped (no storage: a zero-sized type).
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Skip {
        Skip
    }
}
