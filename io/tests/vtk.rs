//! VTK reading (legacy `.vtk`, XML `.vtu`), mesh writing, and the `.vtu` + `.pvd`
//! time series.

// Reads VTK files: needs the feature that reads them.
#![cfg(feature = "vtk")]

use crate::common;

use common::{assert_same_mesh, message, shared_tetmesh, two_tets, TempDir};
use corofem_io::{
    parse_vtk_legacy, parse_vtu, read_mesh, write_vtk_mesh, MeshError, VtkSeries, PVD_NAME,
    SURFACE_PVD_NAME,
};
use vtkio::model::{Attribute, DataSet, Piece};

// ----- inline examples ------------------------------------------------------

/// Legacy ASCII, classic `CELLS n size` layout, with a triangle to skip.
const LEGACY_SMALL: &str = "# vtk DataFile Version 3.0
two tets
ASCII
DATASET UNSTRUCTURED_GRID
POINTS 5 float
0 0 0 1 0 0 0 1 0
0 0 1 1 1 1
CELLS 3 14
3 0 1 2
4 0 1 2 3
4 1 2 3 4
CELL_TYPES 3
5
10
10
";

/// Legacy ASCII 5.1, `OFFSETS` / `CONNECTIVITY` layout.
const LEGACY_51: &str = "# vtk DataFile Version 5.1
two tets
ASCII
DATASET UNSTRUCTURED_GRID
POINTS 5 double
0 0 0 1 0 0 0 1 0
0 0 1 1 1 1
CELLS 4 11
OFFSETS vtktypeint64
0 3 7 11
CONNECTIVITY vtktypeint64
0 1 2 0 1 2 3 1 2 3 4
CELL_TYPES 3
5
10
10
";

/// XML, ASCII data arrays.
const VTU_SMALL: &str = r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
  <UnstructuredGrid>
    <Piece NumberOfPoints="5" NumberOfCells="3">
      <Points>
        <DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0 0 0 1 1 1 1</DataArray>
      </Points>
      <Cells>
        <DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 0 1 2 3 1 2 3 4</DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii">3 7 11</DataArray>
        <DataArray type="UInt8" Name="types" format="ascii">5 10 10</DataArray>
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"#;

/// Output of VTK 9.7's `vtkXMLUnstructuredGridWriter` (binary mode, zlib
/// compression, `header_type="UInt32"`, Float32 points, Int64 connectivity) for
/// the two tets plus a triangle.
const VTU_VTK_ZLIB: &str = r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian" header_type="UInt32" compressor="vtkZLibDataCompressor">
  <UnstructuredGrid>
    <Piece NumberOfPoints="5" NumberOfCells="3">
      <PointData>
      </PointData>
      <CellData>
      </CellData>
      <Points>
        <DataArray type="Float32" Name="Points" NumberOfComponents="3" format="binary" RangeMin="0" RangeMax="1.7320508075688772">
          AQAAAACAAAA8AAAAEwAAAA==eF5jYEAGDfYoXKx8BAYAT1YEew==
          <InformationKey name="L2_NORM_RANGE" location="vtkDataArray" length="2">
            <Value index="0">
              0
            </Value>
            <Value index="1">
              1.7320508076
            </Value>
          </InformationKey>
        </DataArray>
      </Points>
      <Cells>
        <DataArray type="Int64" Name="connectivity" format="binary" RangeMin="0" RangeMax="4">
          AQAAAACAAABYAAAAGQAAAA==eF5jYIAARijNxIAK0MWZCYizQGkAAugAFA==
        </DataArray>
        <DataArray type="Int64" Name="offsets" format="binary" RangeMin="3" RangeMax="11">
          AQAAAACAAAAYAAAAEAAAAA==eF5jZoAAdijNDaUBASgAFg==
        </DataArray>
        <DataArray type="UInt8" Name="types" format="binary" RangeMin="5" RangeMax="10">
          AQAAAACAAAADAAAACwAAAA==eF5j5eICAAAwABo=
        </DataArray>
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"#;

#[test]
fn vtu_written_by_vtk_with_zlib() {
    assert_eq!(
        parse_vtu(VTU_VTK_ZLIB.as_bytes(), "vtk.vtu").unwrap(),
        two_tets()
    );
}

/// vtkio 0.7 slices compressed data without bounds checks; a truncated block
/// must give an error (not a panic, and no panic message).
#[test]
fn vtu_truncated_compressed_block_is_an_error() {
    let text = VTU_VTK_ZLIB.replace(
        "AQAAAACAAAA8AAAAEwAAAA==eF5jYEAGDfYoXKx8BAYAT1YEew==",
        "AQAAAACAAAA8AAAAEwAAAA==eF5j",
    );
    let e = parse_vtu(text.as_bytes(), "cut.vtu").unwrap_err();
    assert!(matches!(e, MeshError::Parse { .. }), "{e:?}");
    message(&e, "cut.vtu", None);
}

#[test]
fn legacy_ascii_inline() {
    let mesh = parse_vtk_legacy(LEGACY_SMALL.as_bytes(), "small.vtk").unwrap();
    assert_eq!(mesh, two_tets());
    let mesh = parse_vtk_legacy(LEGACY_51.as_bytes(), "small.vtk").unwrap();
    assert_eq!(mesh, two_tets());
}

#[test]
fn legacy_binary_inline() {
    // Legacy binary data is big-endian.
    let mut b =
        b"# vtk DataFile Version 3.0\nbin\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 double\n"
            .to_vec();
    for p in two_tets().nodes {
        for c in p {
            b.extend_from_slice(&c.to_be_bytes());
        }
    }
    b.extend_from_slice(b"\nCELLS 2 10\n");
    for v in [4, 0, 1, 2, 3, 4, 1, 2, 3, 4i32] {
        b.extend_from_slice(&v.to_be_bytes());
    }
    b.extend_from_slice(b"\nCELL_TYPES 2\n");
    for v in [10i32, 10] {
        b.extend_from_slice(&v.to_be_bytes());
    }
    b.push(b'\n');
    assert_eq!(parse_vtk_legacy(&b, "bin.vtk").unwrap(), two_tets());
}

#[test]
fn vtu_ascii_inline() {
    assert_eq!(
        parse_vtu(VTU_SMALL.as_bytes(), "small.vtu").unwrap(),
        two_tets()
    );
}

#[test]
fn write_then_read_small_mesh() {
    let dir = TempDir::new("vtk-small");
    for name in ["m.vtk", "m.vtu", "UPPER.VTU"] {
        let path = dir.path().join(name);
        write_vtk_mesh(&path, &two_tets()).unwrap();
        assert_eq!(read_mesh(&path).unwrap(), two_tets(), "{name}");
    }
    let e = write_vtk_mesh(&dir.path().join("m.vtp"), &two_tets()).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
    assert!(e.to_string().contains("m.vtp"), "{e}");
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn shared_meshes_through_vtk_and_vtu() {
    for name in ["sofa_liver.tetmesh", "bunny_ftw_1k.tetmesh"] {
        let mesh = shared_tetmesh(name);
        let dir = TempDir::new(&format!("vtk-shared-{name}"));
        for ext in ["vtk", "vtu"] {
            let path = dir.path().join(format!("mesh.{ext}"));
            write_vtk_mesh(&path, &mesh).unwrap();
            let back = read_mesh(&path).unwrap();
            assert_same_mesh(&back, &mesh, 0.0);
        }
    }
}

// ----- malformed input ------------------------------------------------------

#[test]
fn error_huge_counts() {
    let text = LEGACY_SMALL.replace("POINTS 5 float", "POINTS 4000000000 float");
    let e = parse_vtk_legacy(text.as_bytes(), "bad.vtk").unwrap_err();
    let msg = message(&e, "bad.vtk", Some(5));
    assert!(matches!(e, MeshError::TooLarge { .. }), "{e:?}");
    assert!(msg.contains("point count 4000000000"), "{msg}");

    let text = LEGACY_SMALL.replace("CELLS 3 14", "CELLS 300000000 14");
    let e = parse_vtk_legacy(text.as_bytes(), "bad.vtk").unwrap_err();
    message(&e, "bad.vtk", Some(8));

    let text = VTU_SMALL.replace("NumberOfCells=\"3\"", "NumberOfCells=\"12345678901\"");
    let e = parse_vtu(text.as_bytes(), "bad.vtu").unwrap_err();
    let msg = message(&e, "bad.vtu", Some(4));
    assert!(msg.contains("cell count 12345678901"), "{msg}");
}

#[test]
fn error_bad_numbers() {
    let text = LEGACY_SMALL.replace("POINTS 5 float", "POINTS five float");
    let e = parse_vtk_legacy(text.as_bytes(), "bad.vtk").unwrap_err();
    let msg = message(&e, "bad.vtk", Some(5));
    assert!(matches!(e, MeshError::BadNumber { .. }), "{e:?}");
    assert!(msg.contains("\"five\""), "{msg}");

    let text = LEGACY_SMALL.replace("0 0 1 1 1 1", "0 0 1 1 x 1");
    let e = parse_vtk_legacy(text.as_bytes(), "bad.vtk").unwrap_err();
    assert!(matches!(e, MeshError::Parse { .. }), "{e:?}");
    message(&e, "bad.vtk", None);

    let text = VTU_SMALL.replace("0 0 1 1 1 1<", "0 0 1 1 x 1<");
    let e = parse_vtu(text.as_bytes(), "bad.vtu").unwrap_err();
    assert!(matches!(e, MeshError::Parse { .. }), "{e:?}");
    message(&e, "bad.vtu", None);
}

#[test]
fn error_truncated_and_wrong_counts() {
    let cut = &LEGACY_SMALL[..LEGACY_SMALL.find("4 1 2 3 4").unwrap()];
    let e = parse_vtk_legacy(cut.as_bytes(), "bad.vtk").unwrap_err();
    assert!(matches!(e, MeshError::Parse { .. }), "{e:?}");
    message(&e, "bad.vtk", None);

    let cut = &VTU_SMALL[..VTU_SMALL.find("</Cells>").unwrap()];
    let e = parse_vtu(cut.as_bytes(), "bad.vtu").unwrap_err();
    message(&e, "bad.vtu", None);

    // 5 declared points, only 4 given.
    let text = VTU_SMALL.replace("0 0 1 1 1 1<", "0 0 1<");
    let e = parse_vtu(text.as_bytes(), "bad.vtu").unwrap_err();
    message(&e, "bad.vtu", None);

    // Fewer cell types than cells.
    let text = VTU_SMALL.replace(">5 10 10<", ">5 10<");
    let e = parse_vtu(text.as_bytes(), "bad.vtu").unwrap_err();
    message(&e, "bad.vtu", None);
}

#[test]
fn error_index_out_of_range() {
    let text = LEGACY_SMALL.replace("4 1 2 3 4", "4 1 2 3 5");
    let e = parse_vtk_legacy(text.as_bytes(), "bad.vtk").unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::IndexOutOfRange {
                index: 5,
                nodes: 5,
                ..
            }
        ),
        "{e:?}"
    );
    message(&e, "bad.vtk", None);
}

#[test]
fn error_no_tets_or_not_a_grid() {
    let text = LEGACY_SMALL
        .replace("CELLS 3 14\n", "CELLS 1 4\n")
        .replace("4 0 1 2 3\n4 1 2 3 4\n", "")
        .replace("CELL_TYPES 3\n5\n10\n10\n", "CELL_TYPES 1\n5\n");
    let e = parse_vtk_legacy(text.as_bytes(), "bad.vtk").unwrap_err();
    assert!(
        matches!(e, MeshError::NoTetrahedra { skipped: 1, .. }),
        "{e:?}"
    );

    // A quadratic (10-point) tetrahedron: skipped, with the advice to
    // mesh with first-order elements.
    let points: String = (0..10).map(|i| format!("{i} 0 {}\n", i % 3)).collect();
    let quadratic = format!(
        "# vtk DataFile Version 3.0\nquadratic\nASCII\nDATASET UNSTRUCTURED_GRID\n\
         POINTS 10 float\n{points}CELLS 1 11\n10 0 1 2 3 4 5 6 7 8 9\nCELL_TYPES 1\n24\n"
    );
    let e = parse_vtk_legacy(quadratic.as_bytes(), "bad.vtk").unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::NoTetrahedra {
                skipped: 1,
                higher_order: 1,
                ..
            }
        ),
        "{e:?}"
    );
    let msg = message(&e, "bad.vtk", None);
    assert!(msg.contains("mesh with first-order elements"), "{msg}");

    let poly = "# vtk DataFile Version 3.0\nsurface\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 2\n";
    let e = parse_vtk_legacy(poly.as_bytes(), "bad.vtk").unwrap_err();
    let msg = message(&e, "bad.vtk", None);
    assert!(
        msg.contains("expected an unstructured grid, found poly data"),
        "{msg}"
    );
}

#[test]
fn error_missing_vtu_file() {
    let dir = TempDir::new("vtk-missing");
    let path = dir.path().join("missing.vtu");
    let e = read_mesh(&path).unwrap_err();
    assert!(matches!(e, MeshError::Io { .. }), "{e:?}");
    message(&e, &path.display().to_string(), None);
}

// ----- time series ----------------------------------------------------------

/// The point-data array `name` of a `.vtu` file, read with vtkio directly.
fn point_array(path: &std::path::Path, name: &str) -> Option<Vec<f32>> {
    let vtk = vtkio::Vtk::import(path).unwrap();
    let DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
        panic!("not an unstructured grid");
    };
    let Piece::Inline(piece) = pieces.into_iter().next().unwrap() else {
        panic!("not inline");
    };
    piece.data.point.into_iter().find_map(|a| match a {
        Attribute::DataArray(d) if d.name == name => {
            assert_eq!(d.elem.num_comp(), 3);
            d.data.cast_into::<f32>()
        }
        _ => None,
    })
}

#[test]
fn series_writes_frames_and_pvd() {
    let dir = TempDir::new("vtk-series");
    let out = dir.path().join("run/nested");
    let mesh = two_tets();
    let mut series = VtkSeries::create(&out, &mesh.tets).unwrap();
    assert_eq!(series.pvd_path(), out.join(PVD_NAME));
    let times = [0.0, 0.001, 0.0025];
    for (k, &t) in times.iter().enumerate() {
        let pos: Vec<[f32; 3]> = mesh
            .nodes
            .iter()
            .map(|p| [p[0] as f32 + k as f32, p[1] as f32, p[2] as f32 * 0.5])
            .collect();
        let vel: Vec<[f32; 3]> = (0..pos.len()).map(|i| [i as f32, k as f32, -1.5]).collect();
        series.write_frame(t, &pos, &vel).unwrap();

        // Frame file: points are the positions, cells the tets, "velocity" present.
        let frame = series.frame_path(k);
        assert!(frame.ends_with(format!("frame_{k:06}.vtu")));
        let back = read_mesh(&frame).unwrap();
        assert_eq!(back.tets, mesh.tets);
        for (p, q) in back.nodes.iter().zip(&pos) {
            assert_eq!(*p, q.map(f64::from));
        }
        let v = point_array(&frame, "velocity").expect("velocity array");
        assert_eq!(v, vel.iter().flatten().copied().collect::<Vec<_>>());
    }
    assert_eq!(series.frames(), 3);

    // The .pvd is valid after every frame; check its final content.
    let pvd = std::fs::read_to_string(out.join(PVD_NAME)).unwrap();
    assert!(
        pvd.starts_with("<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\""),
        "{pvd}"
    );
    assert!(pvd.ends_with("  </Collection>\n</VTKFile>\n"), "{pvd}");
    assert_eq!(pvd.matches("<DataSet ").count(), 3, "{pvd}");
    assert!(
        pvd.contains("timestep=\"0.001\" group=\"\" part=\"0\" file=\"frame_000001.vtu\""),
        "{pvd}"
    );
    assert!(pvd.contains("timestep=\"0.0025\""), "{pvd}");
    series.finish().unwrap();
    assert_eq!(std::fs::read_to_string(out.join(PVD_NAME)).unwrap(), pvd);
}

#[test]
fn a_surface_series_sits_beside_the_volume_series() {
    let dir = TempDir::new("vtk-surface");
    let mesh = two_tets();
    let pos: Vec<[f32; 3]> = mesh.nodes.iter().map(|p| p.map(|c| c as f32)).collect();
    let mut volume = VtkSeries::create(dir.path(), &mesh.tets).unwrap();
    volume.write_frame(0.0, &pos, &[]).unwrap();
    let tris = [[0u32, 1, 2], [1, 3, 2]];
    let verts = [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.5],
    ];
    let normals = [[0.0f32, 0.0, 1.0]; 4];
    let mut surface = VtkSeries::create_surface(dir.path(), &tris).unwrap();
    assert_eq!(surface.pvd_path(), dir.path().join(SURFACE_PVD_NAME));
    surface.write_frame(0.0, &verts, &normals).unwrap();
    surface.write_frame(0.1, &verts, &normals).unwrap();
    let frame = surface.frame_path(1);
    assert!(frame.ends_with("surface_000001.vtu"));
    assert_eq!(
        point_array(&frame, "normal").expect("normal array"),
        normals.iter().flatten().copied().collect::<Vec<_>>()
    );
    let vtk = vtkio::Vtk::import(&frame).unwrap();
    let DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
        panic!("not an unstructured grid");
    };
    let Piece::Inline(piece) = pieces.into_iter().next().unwrap() else {
        panic!("not inline");
    };
    assert_eq!(piece.cells.types, vec![vtkio::model::CellType::Triangle; 2]);
    let (connectivity, offsets) = piece.cells.cell_verts.into_xml();
    assert_eq!(offsets, vec![3, 6]);
    assert_eq!(connectivity, vec![0, 1, 2, 1, 3, 2]);
    // Each series lists its own frames.
    let pvd = std::fs::read_to_string(dir.path().join(SURFACE_PVD_NAME)).unwrap();
    assert_eq!(pvd.matches("file=\"surface_").count(), 2, "{pvd}");
    let pvd = std::fs::read_to_string(dir.path().join(PVD_NAME)).unwrap();
    assert_eq!(pvd.matches("<DataSet ").count(), 1, "{pvd}");
    assert!(pvd.contains("file=\"frame_000000.vtu\""), "{pvd}");
}

#[test]
fn series_without_velocities_and_dropped_without_finish() {
    let dir = TempDir::new("vtk-series-drop");
    let mesh = two_tets();
    let pos: Vec<[f32; 3]> = mesh.nodes.iter().map(|p| p.map(|c| c as f32)).collect();
    {
        let mut series = VtkSeries::create(dir.path(), &mesh.tets).unwrap();
        series.write_frame(0.5, &pos, &[]).unwrap();
        assert!(point_array(&series.frame_path(0), "velocity").is_none());
    }
    let pvd = std::fs::read_to_string(dir.path().join(PVD_NAME)).unwrap();
    assert_eq!(pvd.matches("<DataSet ").count(), 1, "{pvd}");
    assert!(pvd.ends_with("</VTKFile>\n"));
}

#[test]
fn series_rejects_inconsistent_frames() {
    let dir = TempDir::new("vtk-series-bad");
    let mesh = two_tets();
    let pos: Vec<[f32; 3]> = mesh.nodes.iter().map(|p| p.map(|c| c as f32)).collect();
    let mut series = VtkSeries::create(dir.path(), &mesh.tets).unwrap();

    // Fewer positions than the connectivity needs.
    let e = series.write_frame(0.0, &pos[..4], &[]).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
    assert!(e.to_string().contains("uses 5 nodes but only 4"), "{e}");
    // Velocity count mismatch, non-finite time.
    let e = series.write_frame(0.0, &pos, &[[0.0; 3]; 2]).unwrap_err();
    assert!(e.to_string().contains("expected 5 velocities"), "{e}");
    let e = series.write_frame(f64::NAN, &pos, &[]).unwrap_err();
    assert!(e.to_string().contains("time must be finite"), "{e}");
    assert_eq!(series.frames(), 0);

    // Node count is fixed by the first frame.
    series.write_frame(0.0, &pos, &[]).unwrap();
    let mut more = pos.clone();
    more.push([2.0; 3]);
    let e = series.write_frame(1.0, &more, &[]).unwrap_err();
    assert!(e.to_string().contains("expected 5 positions"), "{e}");
    assert_eq!(series.frames(), 1);
    series.finish().unwrap();
}

#[test]
fn series_reports_uncreatable_directory() {
    let dir = TempDir::new("vtk-series-file");
    let file = dir.write("not_a_dir", "x");
    let e = VtkSeries::create(&file.join("sub"), &[[0, 1, 2, 3]]).unwrap_err();
    assert!(e.to_string().contains("not_a_dir"), "{e}");
}
