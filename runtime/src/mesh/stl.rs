//! STL through `stl_io`, after bounding a binary file's claimed triangle count by its size.
//!
//! `stl_io` takes any file beginning with `solid ` as ASCII, but some binary files begin with
//! `solid` too, and some ASCII files begin with a bare `solid` line that it takes as binary. So the
//! kind is decided here (a file of exactly 84 + 50 n bytes, n being the count at byte 80, is
//! binary), and the crate is shown a first line that makes its probe agree.

use std::collections::HashMap;
use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};
use std::path::Path;

use super::validate::{RawMesh, check_triangle_count};
use super::{Limits, MeshError, error};

const HEADER: u64 = 80;
const COUNT_END: u64 = 84;
const TRIANGLE_BYTES: u64 = 50;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Binary {
        triangles: u32,
    },
    /// ASCII, or a binary file beginning with `solid` whose size does not match the count at
    /// byte 80 (kept for the message).
    Ascii {
        claimed: Option<u32>,
        size: u64,
    },
    /// ASCII whose first line is `solid` without a name: `stl_io` needs `solid NAME`.
    AsciiNameless {
        first_line: u64,
    },
}

/// Reads an ASCII or binary STL file of `size` bytes.
pub(crate) fn read(path: &Path, mut file: File, size: u64, limits: &Limits) -> Result<RawMesh, MeshError> {
    let head = read_head(path, &mut file)?;
    let kind = classify(path, &head, size)?;
    if let Kind::Binary { triangles } = kind {
        check_triangle_count(path, triangles as usize, limits)?;
    }
    let mut source = Spliced::new(file, kind).map_err(|e| MeshError::file(path, format!("cannot be read: {e}")))?;
    let triangles = stl_io::create_stl_reader(&mut source).map_err(|e| parse_error(path, kind, &e))?;
    index_triangles(path, kind, triangles, limits)
}

/// The first bytes of the file (up to 84: a binary header and its triangle count).
fn read_head(path: &Path, file: &mut File) -> Result<Vec<u8>, MeshError> {
    let mut head = Vec::with_capacity(COUNT_END as usize);
    file.by_ref()
        .take(COUNT_END)
        .read_to_end(&mut head)
        .map_err(|e| MeshError::file(path, format!("cannot be read: {e}")))?;
    Ok(head)
}

/// Binary or ASCII, refusing a binary file shorter than its triangle count says.
fn classify(path: &Path, head: &[u8], size: u64) -> Result<Kind, MeshError> {
    let claimed = head.get(HEADER as usize..COUNT_END as usize).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    if let Some(triangles) = claimed
        && binary_size(triangles) == size
    {
        return Ok(Kind::Binary { triangles });
    }
    if let Some(rest) = head.strip_prefix(b"solid") {
        return Ok(match rest.first() {
            Some(b'\n') => Kind::AsciiNameless { first_line: 6 },
            Some(b'\r') if rest.get(1) == Some(&b'\n') => Kind::AsciiNameless { first_line: 7 },
            _ => Kind::Ascii { claimed, size },
        });
    }
    let Some(triangles) = claimed else {
        let message = format!(
            "has {size} bytes, fewer than the 84 of a binary STL header, and does not begin with \"solid\": \
             the file is truncated or not an STL file"
        );
        return Err(MeshError::file(path, message));
    };
    if binary_size(triangles) > size {
        let message = format!(
            "the binary STL header claims {triangles} triangles ({}) but the file has {size} bytes: \
             the file is truncated or not an STL file",
            error::bytes(binary_size(triangles).into())
        );
        return Err(MeshError::file(path, message));
    }
    Ok(Kind::Binary { triangles })
}

fn binary_size(triangles: u32) -> u64 {
    COUNT_END + TRIANGLE_BYTES * u64::from(triangles)
}

fn parse_error(path: &Path, kind: Kind, e: &io::Error) -> MeshError {
    let message = match kind {
        Kind::Binary { .. } => format!("the binary STL could not be read: {e}: the file is truncated or corrupt"),
        Kind::Ascii { claimed: Some(triangles), size } => format!(
            "the ASCII STL could not be read: {e}: the file is truncated or malformed; if it is a binary STL \
             (whose header begins with \"solid\"), its header claims {triangles} triangles ({}) but the file has \
             {size} bytes",
            error::bytes(binary_size(triangles).into())
        ),
        Kind::Ascii { .. } | Kind::AsciiNameless { .. } => {
            format!("the ASCII STL could not be read: {e}: the file is truncated or malformed")
        }
    };
    MeshError::file(path, message)
}

/// Shares the vertices that triangles have in common (same bits, `-0.0` as `0.0`), stopping at
/// the triangle limit.
fn index_triangles(
    path: &Path,
    kind: Kind,
    triangles: impl Iterator<Item = io::Result<stl_io::Triangle>>,
    limits: &Limits,
) -> Result<RawMesh, MeshError> {
    let mut raw = RawMesh::default();
    let mut shared: HashMap<[u32; 3], u32> = HashMap::new();
    for (count, triangle) in triangles.enumerate() {
        check_triangle_count(path, count + 1, limits)?;
        let triangle = triangle.map_err(|e| parse_error(path, kind, &e))?;
        for vertex in triangle.vertices {
            let position = vertex.0.map(|c| c + 0.0);
            let next = u32::try_from(raw.positions.len()).map_err(|_| too_many_vertices(path))?;
            let index = *shared.entry(position.map(f32::to_bits)).or_insert(next);
            if index == next {
                raw.positions.push(position);
            }
            raw.indices.push(index);
        }
    }
    Ok(raw)
}

fn too_many_vertices(path: &Path) -> MeshError {
    MeshError::file(path, "has more than 4 294 967 295 distinct vertices: decimate the mesh")
}

/// The file as `stl_io` should see it: a binary file's 80-byte header replaced by a newline and
/// zeros (so its ASCII probe fails), or a bare `solid` first line replaced by `solid mesh`.
/// Seeks only back to the start, which is all the probe does.
struct Spliced {
    prefix: Vec<u8>,
    file: File,
    skip: u64,
    position: u64,
}

impl Spliced {
    fn new(file: File, kind: Kind) -> io::Result<Spliced> {
        let (prefix, skip) = match kind {
            Kind::Binary { .. } => {
                let mut header = vec![0; HEADER as usize];
                header[0] = b'\n';
                (header, HEADER)
            }
            Kind::Ascii { .. } => (Vec::new(), 0),
            Kind::AsciiNameless { first_line } => (b"solid mesh\n".to_vec(), first_line),
        };
        let mut spliced = Spliced { prefix, file, skip, position: 0 };
        spliced.seek(SeekFrom::Start(0))?;
        Ok(spliced)
    }
}

impl Read for Spliced {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let from_prefix = self.prefix.get(self.position as usize..).unwrap_or_default();
        let n = if from_prefix.is_empty() {
            self.file.read(buf)?
        } else {
            let n = from_prefix.len().min(buf.len());
            buf[..n].copy_from_slice(&from_prefix[..n]);
            n
        };
        self.position += n as u64;
        Ok(n)
    }
}

impl Seek for Spliced {
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        if to != SeekFrom::Start(0) {
            return Err(io::Error::new(io::ErrorKind::Unsupported, "STL reader: only a seek to the start"));
        }
        self.file.seek(SeekFrom::Start(self.skip))?;
        self.position = 0;
        Ok(0)
    }
}
