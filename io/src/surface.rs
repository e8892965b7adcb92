//! Triangle surfaces to embed in a tetrahedral mesh (a scene's `[visual]`):
//! Wavefront OBJ through `tobj`, STL (ASCII and binary) through `stl_io`.
//!
//! **Vertex order.** The vertices come back in the order of the file, so
//! that a program reading the same file can match them one to one:
//! - OBJ: every `v` line, in order, used by a face or not. Objects, groups
//!   and materials (`o`, `g`, `usemtl`, `mtllib`) are ignored: the surface is
//!   one. Polygons are split into fans of triangles `(v₀, vᵢ, vᵢ₊₁)`; points
//!   and lines (`f`/`l` with fewer than three vertices) are skipped.
//!   (`tobj` numbers vertices by first use, per group; a line naming every
//!   vertex in order is put first and groups are left out, so that its
//!   numbering is the file's.)
//! - STL stores triangles only; equal corners (the same bits) are one
//!   vertex, numbered by first appearance.

use std::io::Cursor;
use std::path::Path;

use crate::error::{check_count, MeshError};
use crate::triangles::Surface;

/// The surface file formats [`read_surface`] knows, chosen by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SurfaceFormat {
    /// `.obj`: Wavefront OBJ.
    Obj,
    /// `.stl`: STL, ASCII or binary.
    Stl,
}

impl SurfaceFormat {
    /// The format for a path's extension (case-insensitive): `.obj` or `.stl`.
    pub fn from_path(path: &Path) -> Option<SurfaceFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(SurfaceFormat::Obj),
            "stl" => Some(SurfaceFormat::Stl),
            _ => None,
        }
    }
}

/// Reads a triangle surface from an `.obj` or `.stl` file. The result has
/// at least one triangle, only in-range indices and finite coordinates.
/// Errors name the file as given in `path`.
pub fn read_surface(path: &Path) -> Result<Surface, MeshError> {
    let name = path.display().to_string();
    let format = format_of(path, &name)?;
    let bytes = std::fs::read(path).map_err(|source| MeshError::Io {
        file: name.clone(),
        source,
    })?;
    parse_surface_as(format, &bytes, &name)
}

/// Reads a triangle surface from `bytes`, choosing the format by the
/// extension of `name` (for a file picked in a browser, say), which errors
/// also name.
pub fn parse_surface(bytes: &[u8], name: &str) -> Result<Surface, MeshError> {
    let format = format_of(Path::new(name), name)?;
    parse_surface_as(format, bytes, name)
}

fn format_of(path: &Path, name: &str) -> Result<SurfaceFormat, MeshError> {
    SurfaceFormat::from_path(path).ok_or_else(|| MeshError::UnknownSurfaceExtension {
        file: name.to_owned(),
        extension: path.extension().map(|e| e.to_string_lossy().into_owned()),
    })
}

fn parse_surface_as(format: SurfaceFormat, bytes: &[u8], name: &str) -> Result<Surface, MeshError> {
    let surface = match format {
        SurfaceFormat::Obj => parse_obj(bytes, name)?,
        SurfaceFormat::Stl => parse_stl(bytes, name)?,
    };
    check_surface(surface, name)
}

/// Reads Wavefront OBJ text (see the module docs for what is kept).
pub fn parse_obj(bytes: &[u8], name: &str) -> Result<Surface, MeshError> {
    let text = crate::text::utf8(bytes, name)?;
    let count = text.lines().filter(|l| first_word(l) == "v").count();
    let count = check_count(name, None, "vertex", count as u64)?;
    if count == 0 {
        return Err(no_triangles(name));
    }
    // One line naming every vertex in order, first, so that tobj numbers
    // them as the file does; then the file without what splits it into
    // several models. Line numbers in tobj's errors would be off by one,
    // but it reports none.
    let mut buf = String::with_capacity(text.len() + 8 * count);
    buf.push('f');
    for i in 1..=count {
        buf.push(' ');
        buf.push_str(&i.to_string());
    }
    buf.push('\n');
    for line in text.lines() {
        match first_word(line) {
            "o" | "g" | "usemtl" | "mtllib" | "vt" | "vn" | "vp" => {}
            // Faces and lines keep their vertex indices only: the surface
            // needs no texture coordinates or normals, and tobj's handling
            // of their indices overflows on some invalid ones.
            w @ ("f" | "l") => {
                buf.push_str(w);
                for token in line.split_whitespace().skip(1) {
                    buf.push(' ');
                    buf.push_str(token.split('/').next().unwrap_or(""));
                }
            }
            _ => buf.push_str(line),
        }
        buf.push('\n');
    }
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ignore_points: false,
        ignore_lines: false,
    };
    let loaded = tobj::load_obj_buf(&mut Cursor::new(buf.as_bytes()), &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    });
    let (models, _) = loaded.map_err(|e| MeshError::Parse {
        file: name.to_owned(),
        line: None,
        message: format!("OBJ: {e}"),
    })?;
    let [model] = models.as_slice() else {
        return Err(MeshError::Parse {
            file: name.to_owned(),
            line: None,
            message: format!("OBJ: read as {} objects, expected one", models.len()),
        });
    };
    let mesh = &model.mesh;
    let vertices: Vec<[f32; 3]> = mesh
        .positions
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    // The first face is the line put first: its arity is `count`. tobj
    // leaves the arities empty when every face is a triangle.
    let mut triangles = Vec::new();
    let mut at = 0usize;
    let mut arities = mesh.face_arities.iter().map(|&a| a as usize);
    let mut first = true;
    while at < mesh.indices.len() {
        let arity = if mesh.face_arities.is_empty() {
            3
        } else {
            arities.next().unwrap_or(0)
        };
        let Some(face) = mesh.indices.get(at..at + arity) else {
            break;
        };
        at += arity.max(1);
        if std::mem::take(&mut first) {
            continue;
        }
        for k in 1..arity.saturating_sub(1) {
            triangles.push([face[0], face[k], face[k + 1]]);
        }
    }
    if vertices.len() != count {
        return Err(MeshError::CountMismatch {
            file: name.to_owned(),
            line: None,
            what: "vertices".to_owned(),
            declared: count,
            found: vertices.len(),
        });
    }
    Ok(Surface {
        vertices,
        triangles,
    })
}

/// Reads ASCII or binary STL.
pub fn parse_stl(bytes: &[u8], name: &str) -> Result<Surface, MeshError> {
    // A binary STL declares its triangle count at byte 80: check it before
    // stl_io allocates for it.
    if let Some(n) = bytes.get(80..84) {
        if !bytes.starts_with(b"solid") {
            let n = u32::from_le_bytes([n[0], n[1], n[2], n[3]]);
            check_count(name, None, "triangle", u64::from(n))?;
        }
    }
    let read = || stl_io::read_stl(&mut Cursor::new(bytes));
    #[cfg(any(feature = "vtk", feature = "gmsh-binary"))]
    let read = crate::guard::catch_quietly(read).unwrap_or_else(|| {
        Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "the STL parser failed on this input",
        ))
    });
    #[cfg(not(any(feature = "vtk", feature = "gmsh-binary")))]
    let read = read();
    let mesh = read.map_err(|e| MeshError::Parse {
        file: name.to_owned(),
        line: None,
        message: format!("STL: {e}"),
    })?;
    check_count(name, None, "vertex", mesh.vertices.len() as u64)?;
    let vertices = mesh.vertices.iter().map(|v| [v[0], v[1], v[2]]).collect();
    let mut triangles = Vec::with_capacity(mesh.faces.len());
    for f in &mesh.faces {
        let [a, b, c] = f.vertices;
        // Indices below MAX_COUNT, checked above.
        triangles.push([a as u32, b as u32, c as u32]);
    }
    Ok(Surface {
        vertices,
        triangles,
    })
}

fn first_word(line: &str) -> &str {
    line.split_whitespace().next().unwrap_or("")
}

fn no_triangles(name: &str) -> MeshError {
    MeshError::Malformed {
        file: name.to_owned(),
        line: None,
        expected: "at least one triangle".to_owned(),
        found: "none".to_owned(),
    }
}

/// At least one triangle, indices in range, finite coordinates.
fn check_surface(surface: Surface, name: &str) -> Result<Surface, MeshError> {
    if surface.triangles.is_empty() {
        return Err(no_triangles(name));
    }
    let n = surface.vertices.len();
    if let Some(&i) = surface
        .triangles
        .iter()
        .flatten()
        .find(|&&i| i as usize >= n)
    {
        return Err(MeshError::IndexOutOfRange {
            file: name.to_owned(),
            line: None,
            index: u64::from(i),
            nodes: n,
        });
    }
    if let Some(v) = surface
        .vertices
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Err(MeshError::Malformed {
            file: name.to_owned(),
            line: None,
            expected: "finite vertex coordinates".to_owned(),
            found: format!("vertex {v} at {:?}", surface.vertices[v]),
        });
    }
    Ok(surface)
}

#[cfg(test)]
mod tests {
    use super::*;

    const CUBE_QUADS: &str = "\
# a unit square and a pentagon, grouped, with unused and normal data
mtllib nowhere.mtl
o first
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vn 0 0 1
v 9 9 9
g second
usemtl red
f 1//1 2//1 3//1 4//1
v 2 0 0
v 3 0 0
v 3 1 0
v 2.5 2 0
v 2 1 0
o third
f -5 -4 -3 -2 -1
l 1 2
";

    #[test]
    fn obj_keeps_the_file_order_and_fans_polygons() {
        let s = parse_surface(CUBE_QUADS.as_bytes(), "x.obj").unwrap();
        assert_eq!(s.vertices.len(), 10);
        assert_eq!(s.vertices[4], [9.0, 9.0, 9.0], "unused vertices stay");
        assert_eq!(s.vertices[9], [2.0, 1.0, 0.0]);
        assert_eq!(
            s.triangles,
            vec![[0, 1, 2], [0, 2, 3], [5, 6, 7], [5, 7, 8], [5, 8, 9]]
        );
    }

    #[test]
    fn texture_and_normal_indices_are_ignored() {
        // Found by fuzzing: a normal index of −4 with no normals made tobj
        // overflow; `v//vn` and `v/vt/vn` faces keep their vertices.
        let s = parse_obj(
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1//-4 2//-4 3//9\nf 1/2/3 2/1/1 4/7/7\n",
            "t.obj",
        )
        .unwrap();
        assert_eq!(s.triangles, vec![[0, 1, 2], [0, 1, 3]]);
        let crash = include_bytes!("../../fuzz/seeds/surface/tobj_normal_index");
        assert!(parse_surface(&crash[2..], "crash.obj").is_err());
    }

    #[test]
    fn obj_of_triangles_only() {
        let s = parse_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj").unwrap();
        assert_eq!(s.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn bad_obj_files_are_errors() {
        for (text, what) in [
            ("", "at least one triangle"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "at least one triangle"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "OBJ"),
            ("v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3\n", "OBJ"),
            ("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", "finite"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "OBJ"),
        ] {
            let e = parse_surface(text.as_bytes(), "bad.obj").unwrap_err();
            assert!(e.to_string().contains(what), "{text:?}: {e}");
            assert!(e.to_string().starts_with("bad.obj"), "{e}");
        }
        let e = parse_surface(&[0xff, 0xfe], "bad.obj").unwrap_err();
        assert!(e.to_string().contains("UTF-8"), "{e}");
        let e = parse_surface(b"", "surface.ply").unwrap_err();
        assert!(e.to_string().contains(".obj or .stl"), "{e}");
    }

    #[test]
    fn stl_ascii_and_binary() {
        let ascii = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
                     vertex 0 1 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\n\
                     vertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        let s = parse_surface(ascii.as_bytes(), "t.STL").unwrap();
        assert_eq!(s.vertices.len(), 4, "shared corners are one vertex");
        assert_eq!(s.triangles, vec![[0, 1, 2], [1, 3, 2]]);

        let mut bin = vec![0u8; 80];
        bin.extend_from_slice(&1u32.to_le_bytes());
        for v in [
            [0.0f32, 0.0, 1.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        ] {
            for c in v {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        bin.extend_from_slice(&[0, 0]);
        let b = parse_surface(&bin, "t.stl").unwrap();
        assert_eq!(
            b.vertices,
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        );
        assert_eq!(b.triangles, vec![[0, 1, 2]]);

        // Truncated, and a count no file could hold.
        assert!(parse_surface(&bin[..100], "t.stl").is_err());
        let mut huge = bin.clone();
        huge[80..84].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = parse_surface(&huge, "t.stl").unwrap_err();
        assert!(e.to_string().contains("exceeds the limit"), "{e}");
    }
}
