//! Built-in shapes in patient space (RAS millimetres), with outward unit normals and triangles
//! counter-clockwise seen from outside.
//!
//! The round shapes are surfaces of revolution: a profile of rows (a distance along the axis, a
//! radius and a normal) turned about the axis. Neighbouring rows at the same place make a crease
//! (a cap's rim beside the side wall), so no triangles join them.

use std::f32::consts::{PI, TAU};

use glam::{Vec2, Vec3};

use super::{Mesh, MeshError};

/// The most segments (around) or rings (from pole to pole) a shape may have.
pub(crate) const MAX_SEGMENTS: u32 = 4096;
/// A needle's cone is this many radii long (or the whole needle, if that is shorter).
const CONE_RADII: f32 = 3.0;

/// A closed cylinder from `base` to `tip`, with flat caps.
pub(crate) fn cylinder(base: Vec3, tip: Vec3, radius: f32, segments: u32) -> Result<Mesh, MeshError> {
    const SHAPE: &str = "cylinder";
    let (axis, length) = axis_between(SHAPE, base, tip)?;
    positive(SHAPE, "radius", radius)?;
    check_segments(SHAPE, "segments", segments, 3)?;
    let rows = [
        Row::new(0.0, 0.0, Vec2::NEG_X),
        Row::new(0.0, radius, Vec2::NEG_X),
        Row::new(0.0, radius, Vec2::Y),
        Row::new(length, radius, Vec2::Y),
        Row::new(length, radius, Vec2::X),
        Row::new(length, 0.0, Vec2::X),
    ];
    finite(SHAPE, revolve(&Frame::new(base, axis), &rows, segments))
}

/// A needle: a cylindrical shaft of `radius` ending in a cone whose apex is exactly at `tip`.
/// `direction` points from the tip towards the handle; the needle is `length` long, and its cone
/// `3 × radius` (at most `length`). The handle end is closed by a flat cap.
pub(crate) fn needle(tip: Vec3, direction: Vec3, length: f32, radius: f32, segments: u32) -> Result<Mesh, MeshError> {
    const SHAPE: &str = "needle";
    finite_point(SHAPE, "tip", tip)?;
    let axis = unit_direction(SHAPE, direction)?;
    positive(SHAPE, "length", length)?;
    positive(SHAPE, "radius", radius)?;
    check_segments(SHAPE, "segments", segments, 3)?;
    let cone = (CONE_RADII * radius).min(length);
    let slant = Vec2::new(-radius, cone).normalize();
    let mut rows = vec![Row::new(0.0, 0.0, slant), Row::new(cone, radius, slant)];
    if cone < length {
        rows.extend([Row::new(cone, radius, Vec2::Y), Row::new(length, radius, Vec2::Y)]);
    }
    rows.extend([Row::new(length, radius, Vec2::X), Row::new(length, 0.0, Vec2::X)]);
    finite(SHAPE, revolve(&Frame::new(tip, axis), &rows, segments))
}

/// A UV sphere: `rings` bands from pole to pole (the poles on the superior axis), `segments`
/// around.
pub fn sphere(centre: Vec3, radius: f32, rings: u32, segments: u32) -> Result<Mesh, MeshError> {
    const SHAPE: &str = "sphere";
    finite_point(SHAPE, "centre", centre)?;
    positive(SHAPE, "radius", radius)?;
    check_segments(SHAPE, "rings", rings, 2)?;
    check_segments(SHAPE, "segments", segments, 3)?;
    let rows: Vec<Row> = (0..=rings)
        .map(|ring| {
            let polar = PI * ring as f32 / rings as f32;
            // The poles exactly on the axis: sin(PI) is not quite zero in f32.
            let (sin, cos) = match ring {
                0 => (0.0, 1.0),
                r if r == rings => (0.0, -1.0),
                _ => polar.sin_cos(),
            };
            Row::new(-radius * cos, radius * sin, Vec2::new(-cos, sin))
        })
        .collect();
    finite(SHAPE, revolve(&Frame::new(centre, Vec3::Z), &rows, segments))
}

/// An axis-aligned box from `min` to `max`: 12 triangles on 24 vertices, so each face has its own
/// flat normal.
pub(crate) fn cuboid(min: Vec3, max: Vec3) -> Result<Mesh, MeshError> {
    const SHAPE: &str = "cuboid";
    finite_point(SHAPE, "min", min)?;
    finite_point(SHAPE, "max", max)?;
    if !min.cmplt(max).all() {
        let message = format!("max {max} must exceed min {min} on every axis: the box has no volume");
        return Err(MeshError::shape(SHAPE, message));
    }
    let mut mesh = Mesh::default();
    for axis in 0..3 {
        for outward in [-1.0, 1.0] {
            push_box_face(&mut mesh, min, max, axis, outward);
        }
    }
    finite(SHAPE, mesh)
}

/// One face of a box: the side of `axis` facing `outward` (±1), counter-clockwise from outside.
fn push_box_face(mesh: &mut Mesh, min: Vec3, max: Vec3, axis: usize, outward: f32) {
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    // Counter-clockwise about +axis, since e_a × e_b = e_axis; reversed for the face looking down it.
    let mut corners = [(false, false), (true, false), (true, true), (false, true)];
    if outward < 0.0 {
        corners.reverse();
    }
    let first = mesh.positions.len() as u32;
    let mut normal = Vec3::ZERO;
    normal[axis] = outward;
    for (high_a, high_b) in corners {
        let mut p = if outward > 0.0 { max } else { min };
        p[a] = if high_a { max[a] } else { min[a] };
        p[b] = if high_b { max[b] } else { min[b] };
        mesh.positions.push(p.into());
        mesh.normals.push(normal.into());
    }
    mesh.indices.extend([first, first + 1, first + 2, first, first + 2, first + 3]);
}

/// A row of a profile: `axial` millimetres along the axis, `radius` from it, and the normal as
/// (along the axis, away from it).
#[derive(Debug, Clone, Copy)]
struct Row {
    axial: f32,
    radius: f32,
    normal: Vec2,
}

impl Row {
    fn new(axial: f32, radius: f32, normal: Vec2) -> Row {
        Row { axial, radius, normal }
    }
}

/// Where a profile is turned: `origin` on the axis, and a right-handed frame `u × v = axis`.
struct Frame {
    origin: Vec3,
    axis: Vec3,
    u: Vec3,
    v: Vec3,
}

impl Frame {
    fn new(origin: Vec3, axis: Vec3) -> Frame {
        let u = axis.any_orthonormal_vector();
        Frame { origin, axis, u, v: axis.cross(u) }
    }
}

/// Turns `rows` (ordered along the axis from one end to the other) about the frame's axis. Each
/// row becomes `segments` vertices; a row on the axis is a pole, so its band has one triangle per
/// segment instead of two.
fn revolve(frame: &Frame, rows: &[Row], segments: u32) -> Mesh {
    let mut mesh = Mesh::default();
    let directions: Vec<Vec3> = (0..segments)
        .map(|i| {
            let (sin, cos) = (TAU * i as f32 / segments as f32).sin_cos();
            frame.u * cos + frame.v * sin
        })
        .collect();
    for row in rows {
        for &radial in &directions {
            let position = frame.origin + frame.axis * row.axial + radial * row.radius;
            let normal = frame.axis * row.normal.x + radial * row.normal.y;
            mesh.positions.push(position.into());
            mesh.normals.push(normal.normalize_or(frame.axis).into());
        }
    }
    for (band, pair) in rows.windows(2).enumerate() {
        let crease = pair[0].axial == pair[1].axial && pair[0].radius == pair[1].radius;
        if !crease {
            push_band(&mut mesh, band as u32 * segments, segments, [pair[0].radius > 0.0, pair[1].radius > 0.0]);
        }
    }
    mesh
}

/// The triangles between row `first / segments` and the next; a side on the axis (radius 0)
/// gets none of the quad's two triangles that would be degenerate.
fn push_band(mesh: &mut Mesh, first: u32, segments: u32, off_axis: [bool; 2]) {
    for i in 0..segments {
        let j = (i + 1) % segments;
        let (a, b, c, d) = (first + i, first + j, first + segments + j, first + segments + i);
        if off_axis[0] {
            mesh.indices.extend([a, b, c]);
        }
        if off_axis[1] {
            mesh.indices.extend([a, c, d]);
        }
    }
}

/// Refuses a shape so large that its coordinates overflowed.
fn finite(shape: &'static str, mesh: Mesh) -> Result<Mesh, MeshError> {
    if mesh.positions.iter().flatten().all(|c| c.is_finite()) {
        return Ok(mesh);
    }
    Err(MeshError::shape(shape, "its coordinates overflow: use sizes and positions in millimetres"))
}

fn finite_point(shape: &'static str, name: &str, p: Vec3) -> Result<(), MeshError> {
    if p.is_finite() {
        return Ok(());
    }
    Err(MeshError::shape(shape, format!("{name} {p} must be finite: a point in millimetres")))
}

fn positive(shape: &'static str, name: &str, value: f32) -> Result<(), MeshError> {
    if value.is_finite() && value > 0.0 {
        return Ok(());
    }
    Err(MeshError::shape(shape, format!("{name} must be a finite positive number of millimetres, got {value}")))
}

fn check_segments(shape: &'static str, name: &str, count: u32, least: u32) -> Result<(), MeshError> {
    if (least..=MAX_SEGMENTS).contains(&count) {
        return Ok(());
    }
    Err(MeshError::shape(shape, format!("{name} must be {least} to {MAX_SEGMENTS}, got {count}")))
}

fn unit_direction(shape: &'static str, direction: Vec3) -> Result<Vec3, MeshError> {
    direction.try_normalize().ok_or_else(|| {
        MeshError::shape(shape, format!("direction {direction} must be a finite vector of non-zero length"))
    })
}

/// The unit axis from `base` to `tip` and its length.
fn axis_between(shape: &'static str, base: Vec3, tip: Vec3) -> Result<(Vec3, f32), MeshError> {
    finite_point(shape, "base", base)?;
    finite_point(shape, "tip", tip)?;
    if base == tip {
        return Err(MeshError::shape(shape, format!("tip and base are the same point {tip}: it has no length")));
    }
    let length = base.distance(tip);
    let axis = (tip - base).try_normalize().filter(|_| length.is_finite());
    axis.map(|axis| (axis, length))
        .ok_or_else(|| MeshError::shape(shape, "tip and base are too far apart: use millimetres"))
}
