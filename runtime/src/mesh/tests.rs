//! Loading, transforming and making meshes; every bad input an error with a telling message.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use tempfile::TempDir;

use super::shapes::{cuboid, cylinder, needle, sphere};
use super::{Coordinates, Limits, Mesh, MeshFormat, load, load_with};

/// The unit tetrahedron: corners at the origin and on the three axes, faces outward.
const TETRA: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
const TETRA_FACES: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

fn write(dir: &TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).expect("write test file");
    path
}

fn load_ok(path: &Path) -> Mesh {
    load(path, &Limits::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn load_err(path: &Path) -> String {
    match load(path, &Limits::default()) {
        Ok(mesh) => panic!("{} loaded ({} triangles), expected an error", path.display(), mesh.triangle_count()),
        Err(e) => e.to_string(),
    }
}

fn assert_mentions(message: &str, words: &[&str]) {
    for word in words {
        assert!(message.contains(word), "{message:?} does not mention {word:?}");
    }
}

/// The enclosed volume by the divergence theorem: positive when the winding is outward.
fn signed_volume(mesh: &Mesh) -> f64 {
    let p = |i: u32| Vec3::from(mesh.positions[i as usize]).as_dvec3();
    mesh.indices.chunks_exact(3).map(|t| p(t[0]).dot(p(t[1]).cross(p(t[2]))) / 6.0).sum()
}

/// Every normal unit length, and every triangle of some area winding the way its normals point.
fn assert_consistent(mesh: &Mesh) {
    assert_eq!(mesh.normals.len(), mesh.positions.len());
    for n in &mesh.normals {
        assert!((Vec3::from(*n).length() - 1.0).abs() < 1e-4, "normal {n:?} is not unit length");
    }
    for t in mesh.indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(mesh.positions[i as usize]));
        let face = (b - a).cross(c - a);
        if face.length() > 1e-6 {
            let vertex_normals: Vec3 = t.iter().map(|&i| Vec3::from(mesh.normals[i as usize])).sum();
            assert!(face.dot(vertex_normals) > 0.0, "triangle {t:?} winds against its normals");
        }
    }
}

fn assert_tetrahedron(mesh: &Mesh) {
    assert_eq!(mesh.triangle_count(), 4);
    assert_eq!(mesh.positions.len(), 4);
    assert!((signed_volume(mesh) - 1.0 / 6.0).abs() < 1e-6, "volume {}", signed_volume(mesh));
    assert_consistent(mesh);
    assert_eq!(mesh.bounds(), Some(([0.0; 3], [1.0; 3])));
}

fn tetra_obj() -> String {
    let vertices: String = TETRA.iter().map(|p| format!("v {} {} {}\n", p[0], p[1], p[2])).collect();
    let faces: String = TETRA_FACES.iter().map(|f| format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1)).collect();
    vertices + &faces
}

fn tetra_ascii_stl(first_line: &str) -> String {
    let mut text = format!("{first_line}\n");
    for face in TETRA_FACES {
        text += "  facet normal 0 0 0\n    outer loop\n";
        for i in face {
            let p = TETRA[i as usize];
            text += &format!("      vertex {} {} {}\n", p[0], p[1], p[2]);
        }
        text += "    endloop\n  endfacet\n";
    }
    text + "endsolid tet\n"
}

fn binary_stl(header: &[u8], triangles: &[[[f32; 3]; 3]], claimed: u32) -> Vec<u8> {
    let mut bytes = header.to_vec();
    bytes.resize(80, b' ');
    bytes.extend(claimed.to_le_bytes());
    for triangle in triangles {
        bytes.extend([0u8; 12]);
        for c in triangle.iter().flatten() {
            bytes.extend(c.to_le_bytes());
        }
        bytes.extend([0u8; 2]);
    }
    bytes
}

fn tetra_triangles() -> Vec<[[f32; 3]; 3]> {
    TETRA_FACES.iter().map(|f| f.map(|i| TETRA[i as usize])).collect()
}

fn ascii_ply(vertices: &[[f32; 3]], faces: &[&[i64]], claimed_faces: usize) -> String {
    let mut text = format!(
        "ply\nformat ascii 1.0\ncomment test\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {claimed_faces}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len()
    );
    for p in vertices {
        text += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for face in faces {
        let corners: Vec<String> = face.iter().map(i64::to_string).collect();
        text += &format!("{} {}\n", face.len(), corners.join(" "));
    }
    text
}

fn binary_ply(vertices: &[[f32; 3]], faces: &[[u32; 3]], claimed_faces: usize) -> Vec<u8> {
    let header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {claimed_faces}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len()
    );
    let mut bytes = header.into_bytes();
    for c in vertices.iter().flatten() {
        bytes.extend(c.to_le_bytes());
    }
    for face in faces {
        bytes.push(3);
        for i in face {
            bytes.extend((*i as i32).to_le_bytes());
        }
    }
    bytes
}

fn tetra_face_lists() -> Vec<&'static [i64]> {
    vec![&[0, 2, 1], &[0, 1, 3], &[0, 3, 2], &[1, 2, 3]]
}

// ---- loading each format ----

#[test]
fn obj_tetrahedron() {
    let dir = TempDir::new().unwrap();
    assert_tetrahedron(&load_ok(&write(&dir, "tet.obj", tetra_obj().as_bytes())));
}

#[test]
fn ascii_stl_tetrahedron() {
    let dir = TempDir::new().unwrap();
    assert_tetrahedron(&load_ok(&write(&dir, "tet.stl", tetra_ascii_stl("solid tet").as_bytes())));
}

#[test]
fn ascii_stl_with_a_bare_solid_line() {
    let dir = TempDir::new().unwrap();
    assert_tetrahedron(&load_ok(&write(&dir, "tet.stl", tetra_ascii_stl("solid").as_bytes())));
    let crlf = tetra_ascii_stl("solid").replace('\n', "\r\n");
    assert_tetrahedron(&load_ok(&write(&dir, "crlf.STL", crlf.as_bytes())));
}

#[test]
fn binary_stl_tetrahedron() {
    let dir = TempDir::new().unwrap();
    let bytes = binary_stl(b"binary tetrahedron", &tetra_triangles(), 4);
    assert_tetrahedron(&load_ok(&write(&dir, "tet.stl", &bytes)));
}

#[test]
fn binary_stl_whose_header_begins_with_solid() {
    let dir = TempDir::new().unwrap();
    let bytes = binary_stl(b"solid exported by a CAD tool", &tetra_triangles(), 4);
    assert_tetrahedron(&load_ok(&write(&dir, "tet.stl", &bytes)));
}

#[test]
fn ascii_ply_tetrahedron() {
    let dir = TempDir::new().unwrap();
    let text = ascii_ply(&TETRA, &tetra_face_lists(), 4);
    assert_tetrahedron(&load_ok(&write(&dir, "tet.ply", text.as_bytes())));
}

#[test]
fn binary_little_endian_ply_tetrahedron() {
    let dir = TempDir::new().unwrap();
    let bytes = binary_ply(&TETRA, &TETRA_FACES, 4);
    assert_tetrahedron(&load_ok(&write(&dir, "tet.ply", &bytes)));
}

#[test]
fn ply_normals_and_extra_elements_are_read() {
    let dir = TempDir::new().unwrap();
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n\
                property float nx\nproperty float ny\nproperty float nz\nelement face 1\n\
                property list uchar uint vertex_index\nelement edge 1\nproperty int vertex1\nproperty int vertex2\n\
                end_header\n0 0 0 0 0 2\n1 0 0 0 0 2\n0 1 0 0 0 2\n3 0 1 2\n0 1\n";
    let mesh = load_ok(&write(&dir, "tri.ply", text.as_bytes()));
    assert_eq!(mesh.indices, [0, 1, 2]);
    assert_eq!(mesh.normals, [[0.0, 0.0, 1.0]; 3]);
}

#[test]
fn quads_become_two_triangles() {
    let dir = TempDir::new().unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    let ply = ascii_ply(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]], &[&[0, 1, 2, 3]], 1);
    for path in [write(&dir, "quad.obj", obj.as_bytes()), write(&dir, "quad.ply", ply.as_bytes())] {
        let mesh = load_ok(&path);
        assert_eq!(mesh.triangle_count(), 2, "{}", path.display());
        assert_eq!(mesh.normals, [[0.0, 0.0, 1.0]; 4], "{}", path.display());
    }
}

#[test]
fn obj_normals_are_taken_from_the_file_unless_unusable() {
    let dir = TempDir::new().unwrap();
    let given = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 3\nf 1//1 2//1 3//1\n";
    assert_eq!(load_ok(&write(&dir, "given.obj", given.as_bytes())).normals, [[0.0, 0.0, 1.0]; 3]);
    let broken = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nf 1//1 2//1 3//1\n";
    assert_eq!(load_ok(&write(&dir, "broken.obj", broken.as_bytes())).normals, [[0.0, 0.0, 1.0]; 3]);
    let flipped = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 -1\nf 1//1 2//1 3//1\n";
    assert_eq!(load_ok(&write(&dir, "flipped.obj", flipped.as_bytes())).normals, [[0.0, 0.0, -1.0]; 3]);
}

#[test]
fn degenerate_triangles_are_kept_without_poisoning_normals() {
    let dir = TempDir::new().unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 4 4 4\n";
    let mesh = load_ok(&write(&dir, "flat.obj", obj.as_bytes()));
    assert_eq!(mesh.triangle_count(), 3);
    assert!(mesh.normals.iter().flatten().all(|c| c.is_finite()));
    assert_eq!(mesh.normals[0], [0.0, 0.0, 1.0]);
    assert_eq!(mesh.normals[3], [0.0, 0.0, 1.0], "a vertex of zero-area triangles only gets the fallback");
}

#[test]
fn several_obj_objects_are_merged() {
    let dir = TempDir::new().unwrap();
    let obj = "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv 0 0 5\nv 1 0 5\nv 0 1 5\nf -3 -2 -1\n";
    let mesh = load_ok(&write(&dir, "two.obj", obj.as_bytes()));
    assert_eq!(mesh.triangle_count(), 2);
    assert_eq!(mesh.bounds(), Some(([0.0; 3], [1.0, 1.0, 5.0])));
}

#[test]
fn formats_are_chosen_by_extension_ignoring_case() {
    assert_eq!(MeshFormat::from_path(Path::new("a/needle.STL")), Some(MeshFormat::Stl));
    assert_eq!(MeshFormat::from_path(Path::new("liver.Obj")), Some(MeshFormat::Obj));
    assert_eq!(MeshFormat::from_path(Path::new("vessels.ply")), Some(MeshFormat::Ply));
    assert_eq!(MeshFormat::from_path(Path::new("mesh.vtk")), None);
    assert_eq!(MeshFormat::from_path(Path::new("stl")), None);
}

// ---- coordinates and transforms ----

#[test]
fn lps_negates_x_and_y_and_keeps_the_winding() {
    let dir = TempDir::new().unwrap();
    let path = write(&dir, "tet.obj", tetra_obj().as_bytes());
    let ras = load_ok(&path);
    let mesh = load_with(&path, Coordinates::Lps, &Limits::default()).unwrap();
    for (lps, ras) in mesh.positions.iter().zip(&ras.positions) {
        assert_eq!(*lps, [-ras[0], -ras[1], ras[2]]);
    }
    assert_eq!(mesh.indices, ras.indices);
    assert!((signed_volume(&mesh) - 1.0 / 6.0).abs() < 1e-6);
    assert_consistent(&mesh);
}

#[test]
fn a_mirror_flips_the_winding_so_normals_stay_outward() {
    let mesh = cuboid(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)).unwrap();
    let mirrored = mesh.clone().transformed(Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
    assert!((signed_volume(&mirrored) - 6.0).abs() < 1e-5, "volume {}", signed_volume(&mirrored));
    assert_consistent(&mirrored);
    assert_eq!(mirrored.bounds(), Some(([-1.0, 0.0, 0.0], [0.0, 2.0, 3.0])));
}

#[test]
fn a_rotation_and_translation_move_positions_and_normals() {
    let mesh = cuboid(Vec3::ZERO, Vec3::ONE).unwrap();
    let m = Mat4::from_translation(Vec3::new(10.0, 0.0, 0.0)) * Mat4::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let moved = mesh.transformed(m);
    assert!((signed_volume(&moved) - 1.0).abs() < 1e-4);
    assert_consistent(&moved);
    let (min, max) = moved.bounds().unwrap();
    assert!((Vec3::from(min) - Vec3::new(9.0, 0.0, 0.0)).length() < 1e-5);
    assert!((Vec3::from(max) - Vec3::new(10.0, 1.0, 1.0)).length() < 1e-5);
}

#[test]
fn a_singular_transform_leaves_finite_normals() {
    let flat = cuboid(Vec3::ZERO, Vec3::ONE).unwrap().transformed(Mat4::from_scale(Vec3::new(1.0, 1.0, 0.0)));
    assert!(flat.normals.iter().flatten().all(|c| c.is_finite()));
}

#[test]
fn empty_mesh_has_no_bounds() {
    assert_eq!(Mesh::default().bounds(), None);
    assert_eq!(Mesh::default().triangle_count(), 0);
}

// ---- bad input ----

#[test]
fn truncated_binary_stl_is_refused() {
    let dir = TempDir::new().unwrap();
    let bytes = binary_stl(b"tet", &tetra_triangles()[..2], 4);
    let message = load_err(&write(&dir, "needle.stl", &bytes));
    assert_mentions(&message, &["needle.stl", "claims 4 triangles", "truncated"]);
}

#[test]
fn a_million_triangle_stl_of_one_kilobyte_is_refused() {
    let dir = TempDir::new().unwrap();
    let mut bytes = binary_stl(b"liar", &[], 1_000_000);
    bytes.resize(1024, 0);
    let message = load_err(&write(&dir, "needle.stl", &bytes));
    assert_mentions(&message, &["1000000 triangles", "50 MB", "1024 bytes", "truncated"]);
}

#[test]
fn a_million_triangle_stl_beginning_with_solid_is_refused() {
    let dir = TempDir::new().unwrap();
    let mut bytes = binary_stl(b"solid liar", &[], 1_000_000);
    bytes.resize(1024, 0);
    let message = load_err(&write(&dir, "needle.stl", &bytes));
    assert_mentions(&message, &["ASCII STL", "truncated", "claims 1000000 triangles (50 MB)", "1024 bytes"]);
}

#[test]
fn stl_over_the_triangle_limit_is_refused() {
    let dir = TempDir::new().unwrap();
    let limits = Limits { max_triangles: 3, ..Limits::default() };
    for (name, bytes) in [
        ("binary.stl", binary_stl(b"tet", &tetra_triangles(), 4)),
        ("ascii.stl", tetra_ascii_stl("solid tet").into_bytes()),
        ("tet.obj", tetra_obj().into_bytes()),
        ("tet.ply", binary_ply(&TETRA, &TETRA_FACES, 4)),
    ] {
        let message = load(&write(&dir, name, &bytes), &limits).unwrap_err().to_string();
        assert_mentions(&message, &["4 triangles", "limit of 3"]);
    }
}

#[test]
fn a_file_over_the_size_limit_is_refused_before_reading() {
    let dir = TempDir::new().unwrap();
    let limits = Limits { max_file_bytes: 10, ..Limits::default() };
    let path = write(&dir, "tet.obj", tetra_obj().as_bytes());
    assert_mentions(&load(&path, &limits).unwrap_err().to_string(), &["limit", "max_file_bytes"]);
}

#[test]
fn ply_claiming_a_million_faces_in_a_tiny_file_is_refused() {
    let dir = TempDir::new().unwrap();
    let ascii = ascii_ply(&TETRA, &tetra_face_lists(), 1_000_000);
    let binary = binary_ply(&TETRA, &TETRA_FACES, 1_000_000);
    for (name, bytes) in [("ascii.ply", ascii.into_bytes()), ("binary.ply", binary)] {
        let message = load_err(&write(&dir, name, &bytes));
        assert_mentions(&message, &["1000000 face", "truncated"]);
    }
}

#[test]
fn ply_with_fewer_faces_than_its_header_says_is_refused() {
    let dir = TempDir::new().unwrap();
    let ascii = ascii_ply(&TETRA, &tetra_face_lists(), 5);
    let binary = binary_ply(&TETRA, &TETRA_FACES, 5);
    for (name, bytes) in [("ascii.ply", ascii.into_bytes()), ("binary.ply", binary)] {
        assert_mentions(&load_err(&write(&dir, name, &bytes)), &["truncated"]);
    }
}

#[test]
fn nan_vertices_are_refused_by_index() {
    let dir = TempDir::new().unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv 0 NaN 0\nf 1 2 3\n";
    assert_mentions(&load_err(&write(&dir, "nan.obj", obj.as_bytes())), &["vertex 2", "NaN", "finite"]);
    let mut triangles = tetra_triangles();
    triangles[0][1][2] = f32::INFINITY;
    let stl = binary_stl(b"inf", &triangles, 4);
    assert_mentions(&load_err(&write(&dir, "inf.stl", &stl)), &["vertex 1", "inf", "finite"]);
    let ply = binary_ply(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, f32::NAN]], &[[0, 1, 2]], 1);
    assert_mentions(&load_err(&write(&dir, "nan.ply", &ply)), &["vertex 2", "NaN", "finite"]);
    // The crate's ASCII grammar has no NaN: a parse error.
    let ply = ascii_ply(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, f32::NAN]], &[&[0, 1, 2]], 1);
    assert_mentions(&load_err(&write(&dir, "nan-ascii.ply", ply.as_bytes())), &["vertex", "malformed"]);
}

#[test]
fn indices_out_of_range_are_refused_naming_the_face() {
    let dir = TempDir::new().unwrap();
    let ply = ascii_ply(&TETRA, &[&[0, 2, 1], &[0, 1, 3], &[0, 3, 7]], 3);
    assert_mentions(&load_err(&write(&dir, "bad.ply", ply.as_bytes())), &["face 2", "vertex 7", "out of range"]);
    let binary = binary_ply(&TETRA, &[[0, 2, 1], [9, 1, 3]], 2);
    assert_mentions(&load_err(&write(&dir, "bad-binary.ply", &binary)), &["face 1", "vertex 9", "out of range"]);
    let negative = ascii_ply(&TETRA, &[&[0, -2, 1]], 1);
    assert_mentions(&load_err(&write(&dir, "negative.ply", negative.as_bytes())), &["face 0", "-2", "negative"]);
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n";
    assert_mentions(&load_err(&write(&dir, "bad.obj", obj.as_bytes())), &["out of range"]);
}

#[test]
fn empty_files_are_refused() {
    let dir = TempDir::new().unwrap();
    for name in ["empty.obj", "empty.stl", "empty.ply"] {
        assert_mentions(&load_err(&write(&dir, name, b"")), &["empty"]);
    }
}

#[test]
fn files_without_faces_are_refused() {
    let dir = TempDir::new().unwrap();
    let cases = [
        ("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n".to_string()),
        ("lines.obj", "v 0 0 0\nv 1 0 0\nl 1 2\n".to_string()),
        ("none.stl", "solid none\nendsolid none\n".to_string()),
        ("cloud.ply", ascii_ply(&TETRA, &[], 0)),
    ];
    for (name, text) in cases {
        assert_mentions(&load_err(&write(&dir, name, text.as_bytes())), &["no triangles"]);
    }
    let binary = binary_stl(b"nothing", &[], 0);
    assert_mentions(&load_err(&write(&dir, "none-binary.stl", &binary)), &["no triangles"]);
}

#[test]
fn paths_that_are_not_mesh_files_are_refused() {
    let dir = TempDir::new().unwrap();
    let folder = dir.path().join("folder.stl");
    std::fs::create_dir(&folder).unwrap();
    assert_mentions(&load_err(&folder), &["directory"]);
    assert_mentions(&load_err(&dir.path().join("missing.obj")), &["missing.obj", "cannot be read"]);
    let unknown = write(&dir, "mesh.vtk", b"# vtk DataFile");
    assert_mentions(&load_err(&unknown), &["unknown mesh format", ".obj, .stl or .ply"]);
}

#[test]
fn garbage_is_refused() {
    let dir = TempDir::new().unwrap();
    let noise: Vec<u8> = (0..3000u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
    for name in ["noise.obj", "noise.stl", "noise.ply"] {
        load_err(&write(&dir, name, &noise));
    }
    assert_mentions(&load_err(&write(&dir, "short.stl", b"abc")), &["84", "not an STL"]);
    assert_mentions(&load_err(&write(&dir, "text.ply", b"hello\n")), &["not a PLY"]);
    let headless = b"ply\nformat ascii 1.0\nelement vertex 1\n";
    assert_mentions(&load_err(&write(&dir, "headless.ply", headless)), &["end_header"]);
    let broken = tetra_ascii_stl("solid tet").replace("endloop", "endlop");
    assert_mentions(&load_err(&write(&dir, "broken.stl", broken.as_bytes())), &["ASCII STL", "malformed"]);
    assert_mentions(&load_err(&write(&dir, "bad.obj", b"v 0 zero 0\nf 1 1 1\n")), &["OBJ", "parse"]);
}

// ---- shapes ----

#[test]
fn cuboid_volume_matches() {
    let mesh = cuboid(Vec3::new(-1.0, 2.0, 3.0), Vec3::new(4.0, 5.0, 10.0)).unwrap();
    assert_eq!((mesh.triangle_count(), mesh.positions.len()), (12, 24));
    assert!((signed_volume(&mesh) - 5.0 * 3.0 * 7.0).abs() < 1e-3);
    assert_consistent(&mesh);
}

#[test]
fn sphere_vertices_lie_at_the_radius() {
    let centre = Vec3::new(10.0, -20.0, 30.0);
    let mesh = sphere(centre, 7.5, 12, 24).unwrap();
    for p in &mesh.positions {
        assert!((Vec3::from(*p).distance(centre) - 7.5).abs() < 1e-4, "{p:?}");
    }
    assert_consistent(&mesh);
    assert_eq!(mesh.triangle_count(), 2 * 24 * (12 - 1));
    let volume = signed_volume(&mesh);
    let ball = 4.0 / 3.0 * std::f64::consts::PI * 7.5f64.powi(3);
    assert!(volume > 0.9 * ball && volume < ball, "volume {volume} vs {ball}");
}

#[test]
fn cylinder_volume_is_its_prism() {
    let (base, tip) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(4.0, -2.0, 3.0));
    let mesh = cylinder(base, tip, 2.0, 16).unwrap();
    let polygon = 16.0 / 2.0 * 4.0 * (std::f64::consts::TAU / 16.0).sin();
    assert!((signed_volume(&mesh) - polygon * 5.0).abs() < 1e-3, "{}", signed_volume(&mesh));
    assert_consistent(&mesh);
}

#[test]
fn needle_apex_is_exactly_at_the_tip() {
    let tip = Vec3::new(12.25, -3.5, 40.125);
    let direction = Vec3::new(0.3, 0.5, 1.0);
    let mesh = needle(tip, direction, 80.0, 0.6, 12).unwrap();
    assert!(mesh.positions.contains(&tip.to_array()));
    // Every vertex lies on the handle's side of the tip.
    let axis = direction.normalize();
    assert!(mesh.positions.iter().all(|&p| (Vec3::from(p) - tip).dot(axis) >= 0.0));
    let (_, max_along) = mesh.positions.iter().fold((0.0f32, 0.0f32), |(lo, hi), &p| {
        let along = (Vec3::from(p) - tip).dot(axis);
        (lo.min(along), hi.max(along))
    });
    assert!((max_along - 80.0).abs() < 1e-3);
    assert_consistent(&mesh);
    assert!(signed_volume(&mesh) > 0.0);
    let short = needle(tip, -direction, 1.0, 0.6, 12).unwrap();
    assert!(short.positions.contains(&tip.to_array()));
    assert_consistent(&short);
}

#[test]
fn shapes_refuse_bad_sizes() {
    let nan = Vec3::new(f32::NAN, 0.0, 0.0);
    let errors = [
        (cylinder(Vec3::ZERO, Vec3::ZERO, 1.0, 8).unwrap_err(), "same point"),
        (cylinder(Vec3::ZERO, Vec3::X, 0.0, 8).unwrap_err(), "radius"),
        (cylinder(Vec3::ZERO, Vec3::X, 1.0, 2).unwrap_err(), "segments"),
        (cylinder(Vec3::ZERO, Vec3::X, 1.0, 4097).unwrap_err(), "segments"),
        (cylinder(nan, Vec3::X, 1.0, 8).unwrap_err(), "finite"),
        (needle(Vec3::ZERO, Vec3::ZERO, 10.0, 1.0, 8).unwrap_err(), "direction"),
        (needle(Vec3::ZERO, nan, 10.0, 1.0, 8).unwrap_err(), "direction"),
        (needle(Vec3::ZERO, Vec3::Z, -10.0, 1.0, 8).unwrap_err(), "length"),
        (needle(Vec3::ZERO, Vec3::Z, 10.0, f32::INFINITY, 8).unwrap_err(), "radius"),
        (sphere(Vec3::ZERO, f32::NAN, 8, 8).unwrap_err(), "radius"),
        (sphere(Vec3::ZERO, 1.0, 1, 8).unwrap_err(), "rings"),
        (sphere(Vec3::ZERO, 1.0, 8, 0).unwrap_err(), "segments"),
        (cuboid(Vec3::ONE, Vec3::ZERO).unwrap_err(), "no volume"),
        (cuboid(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0)).unwrap_err(), "no volume"),
        (cuboid(Vec3::ZERO, Vec3::splat(f32::INFINITY)).unwrap_err(), "finite"),
        (sphere(Vec3::splat(f32::MAX), f32::MAX, 8, 8).unwrap_err(), "overflow"),
    ];
    for (error, word) in errors {
        assert_mentions(&error.to_string(), &[word]);
        assert!(error.path().is_none());
    }
}

#[test]
fn shapes_are_closed_and_wound_outward_and_open_or_inverted_surfaces_are_not() {
    let shapes = [
        sphere(Vec3::ZERO, 5.0, 16, 32).unwrap(),
        cuboid(Vec3::ZERO, Vec3::ONE).unwrap(),
        needle(Vec3::ZERO, Vec3::Z, 50.0, 1.0, 24).unwrap(),
        cylinder(Vec3::ZERO, Vec3::X * 3.0, 1.0, 12).unwrap(),
    ];
    for mesh in &shapes {
        assert!(mesh.is_closed_outward(), "{} triangles", mesh.triangle_count());
    }
    let mut open = shapes[1].clone();
    open.indices.truncate(open.indices.len() - 3);
    assert!(!open.is_closed_outward(), "a box without one triangle is open");
    let inverted = shapes[0].clone().transformed(Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
    assert!(inverted.is_closed_outward(), "a mirror flips the winding back outward");
    let mut inside_out = shapes[0].clone();
    inside_out.indices.chunks_exact_mut(3).for_each(|t| t.swap(1, 2));
    assert!(!inside_out.is_closed_outward(), "a surface wound inward is not");
}
