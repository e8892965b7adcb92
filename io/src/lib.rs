//! Host-side mesh input and result output for corofem.
//!
//! * [`read_mesh`] reads a tetrahedral [`Mesh`] from a `.tetmesh`, Gmsh `.msh`
//!   (MSH 4.1 ASCII/binary, MSH 2.x ASCII, MSH 1.0), legacy VTK `.vtk` or XML VTK
//!   `.vtu` file; every failure is a [`MeshError`] whose message names the file and,
//!   where it applies, the line.
//! * [`parse_mesh`] reads the same from bytes, choosing the reader by their
//!   content ([`MeshFormat::detect`]) instead of a file name.
//! * [`mesh_stats`] reports counts, bounding box, volumes, inverted or flat
//!   tetrahedra and the dihedral-angle range; [`drop_unused_nodes`] removes nodes
//!   no tetrahedron uses.
//! * [`read_surface`] reads a triangle [`Surface`] (Wavefront `.obj`, `.stl`)
//!   to embed in a mesh (feature `surface`); [`parse_surface`] reads one from
//!   bytes. [`boundary_surface`] is a mesh's boundary as a surface, and
//!   [`loop_subdivide`] smooths a surface.
//! * [`VtkSeries`] writes a simulation as `.vtu` frames plus a ParaView `.pvd`
//!   collection; [`write_vtk_mesh`] and [`write_tetmesh`] write a single mesh.
//!
//! Third-party parsers do the heavy lifting where good ones exist: `mshio` for
//! binary Gmsh MSH 4.1, `vtkio` for VTK (reading and writing), `tobj` for OBJ
//! and `stl_io` for STL. The `.tetmesh`
//! format and ASCII Gmsh files are parsed by hand (see the [`tetmesh`] and [`gmsh`]
//! modules for why).
//!
//! Features: `vtk` (default) brings `vtkio`, the VTK readers, `write_vtk_mesh` and
//! `VtkSeries`; `gmsh-binary` (default) brings `mshio` and binary MSH 4.1;
//! `surface` (default) brings `tobj`, `stl_io` and the surface readers. Without
//! them the crate needs only `std` and the core and reads `.tetmesh` and ASCII
//! `.msh` (the web demo's wasm module uses it so); a file in a format whose feature
//! is off is a [`MeshError::Unsupported`].
//!
//! ```no_run
//! use std::path::Path;
//! let mut mesh = corofem_io::read_mesh(Path::new("liver.msh"))?;
//! corofem_io::drop_unused_nodes(&mut mesh);
//! let stats = corofem_io::mesh_stats(&mesh);
//! println!("{} nodes, {} tets, min dihedral {:.1}°", stats.nodes, stats.tets, stats.min_dihedral_deg);
//! # Ok::<(), corofem_io::MeshError>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod detect;
mod error;
pub mod gmsh;
#[cfg(any(feature = "vtk", feature = "gmsh-binary"))]
mod guard;
mod heap;
mod mesh;
#[cfg(feature = "vtk")]
mod series;
mod stats;
#[cfg(feature = "surface")]
pub mod surface;
pub mod tetmesh;
mod text;
mod triangles;
#[cfg(feature = "vtk")]
pub mod vtk;

use std::path::Path;

pub use detect::parse_mesh;
pub use error::{MeshError, MAX_COUNT};
pub use gmsh::parse_msh;
pub use heap::to_core;
pub use mesh::{drop_unused_nodes, Mesh};
#[cfg(feature = "vtk")]
pub use series::{VtkSeries, PVD_NAME, SURFACE_PVD_NAME};
pub use stats::{
    dihedral_angles_deg, mesh_stats, tet_volume, unusable, MeshStats, Unusable, ZERO_VOLUME_RTOL,
};
#[cfg(feature = "surface")]
pub use surface::{parse_surface, read_surface, SurfaceFormat};
pub use tetmesh::{format_tetmesh, parse_tetmesh, write_tetmesh};
pub use triangles::{boundary_surface, boundary_triangles, loop_subdivide, Surface};
#[cfg(feature = "vtk")]
pub use vtk::{parse_vtk_legacy, parse_vtu, write_vtk_mesh};

/// The mesh file formats [`read_mesh`] knows, chosen by file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// `.tetmesh`: the project's `tetmesh 1` text format.
    Tetmesh,
    /// `.msh`: Gmsh MSH 4.1 (ASCII or binary), 2.x (ASCII) or 1.0.
    Gmsh,
    /// `.vtk`: legacy VTK unstructured grid (ASCII or binary).
    VtkLegacy,
    /// `.vtu`: XML VTK unstructured grid.
    Vtu,
}

impl MeshFormat {
    /// The format for a path's extension (case-insensitive), if it is one of
    /// `.tetmesh`, `.msh`, `.vtk`, `.vtu`.
    pub fn from_path(path: &Path) -> Option<MeshFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "tetmesh" => Some(MeshFormat::Tetmesh),
            "msh" => Some(MeshFormat::Gmsh),
            "vtk" => Some(MeshFormat::VtkLegacy),
            "vtu" => Some(MeshFormat::Vtu),
            _ => None,
        }
    }
}

/// Reads a tetrahedral mesh, choosing the reader by the file extension
/// (see [`MeshFormat`]; for `.msh` the version comes from the `$MeshFormat` header).
///
/// Only 4-node tetrahedra are kept (Gmsh element type 4, `VTK_TETRA`); other
/// elements or cells are skipped. The result has at least one tetrahedron and only
/// in-range indices; it may have unused nodes (see [`drop_unused_nodes`]).
/// Coordinates are returned in the file's unit.
///
/// Errors name the file as given in `path`.
pub fn read_mesh(path: &Path) -> Result<Mesh, MeshError> {
    let name = path.display().to_string();
    let format = MeshFormat::from_path(path).ok_or_else(|| MeshError::UnknownExtension {
        file: name.clone(),
        extension: path.extension().map(|e| e.to_string_lossy().into_owned()),
    })?;
    let bytes = std::fs::read(path).map_err(|source| MeshError::Io {
        file: name.clone(),
        source,
    })?;
    parse_as(format, &bytes, &name)
}

/// Reads `bytes` as a file of `format`; errors name the file `name`.
fn parse_as(format: MeshFormat, bytes: &[u8], name: &str) -> Result<Mesh, MeshError> {
    match format {
        MeshFormat::Tetmesh => {
            let text = text::utf8(bytes, name)?;
            parse_tetmesh(text, name)
        }
        MeshFormat::Gmsh => parse_msh(bytes, name),
        #[cfg(feature = "vtk")]
        MeshFormat::VtkLegacy => parse_vtk_legacy(bytes, name),
        #[cfg(feature = "vtk")]
        MeshFormat::Vtu => parse_vtu(bytes, name),
        #[cfg(not(feature = "vtk"))]
        MeshFormat::VtkLegacy | MeshFormat::Vtu => Err(MeshError::Unsupported {
            file: name.to_owned(),
            line: None,
            what: "VTK files (.vtk, .vtu) are not read by this build; \
                   save the mesh as .tetmesh or Gmsh .msh"
                .to_owned(),
        }),
    }
}
