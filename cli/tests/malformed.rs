//! Malformed input to the `corofem` binary: truncated files, wrong counts, bad
//! numbers, unknown keys, missing files and huge counts, in scene files and in
//! every mesh format. Each must exit with status 1, name the file and the line
//! or key in its message, and leave no result file (nor any other file)
//! behind. A panic would exit with 101 and fail these tests.

use std::fs;

use crate::common;
use common::{corofem, TempDir};

/// Runs `args` in `dir` and asserts a clean failure: exit status 1 (not a
/// panic's 101), a message on stderr containing every string of `want`, and
/// no file created or left behind. Returns the message.
fn fails(dir: &TempDir, args: &[&str], want: &[&str]) -> String {
    let before = dir.files();
    let o = corofem(args, &dir.0);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
    assert!(err.starts_with("error: "), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    for w in want {
        assert!(err.contains(w), "{args:?}: expected {w:?} in: {err}");
    }
    assert_eq!(dir.files(), before, "{args:?} left files behind");
    assert!(o.stdout.is_empty(), "{args:?} printed a result");
    err
}

/// Runs the scene text as `scene.toml` with `--out result.json --vtk vtk`.
fn scene_fails(dir: &TempDir, scene: &str, want: &[&str]) -> String {
    dir.write("scene.toml", scene);
    fails(
        dir,
        &[
            "run",
            "scene.toml",
            "--out",
            "result.json",
            "--vtk",
            "vtk",
            "--quiet",
        ],
        want,
    )
}

/// A scene that reads `file` and runs 2 steps.
fn mesh_scene(file: &str) -> String {
    format!("[mesh]\nfile = \"{file}\"\n[solver]\nsteps = 2\n")
}

/// Runs a mesh both ways, `corofem run` (through a scene) and `corofem
/// info`, expecting `want` in both messages.
fn mesh_fails(dir: &TempDir, name: &str, bytes: impl AsRef<[u8]>, want: &[&str]) {
    dir.write(name, bytes);
    scene_fails(dir, &mesh_scene(name), want);
    fails(dir, &["info", name], want);
    fs::remove_file(dir.path(name)).unwrap();
    let _ = fs::remove_file(dir.path("scene.toml"));
}

const TET: &str = "tetmesh 1\n5 2\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n0 1 2 3\n1 2 3 4\n";

#[test]
fn the_unspoilt_files_run() {
    // The baselines the other tests spoil, to show they are otherwise valid.
    let dir = TempDir::new("baseline");
    dir.write("m.tetmesh", TET);
    dir.write("scene.toml", mesh_scene("m.tetmesh"));
    let o = corofem(&["run", "scene.toml", "--out", "r.json", "--quiet"], &dir.0);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for (name, text) in [("m.msh", MSH2), ("m.vtk", VTK), ("m.msh", MSH41)] {
        dir.write(name, text);
        let o = corofem(&["info", name], &dir.0);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

#[test]
fn truncated_tetmesh_names_the_line() {
    let dir = TempDir::new("tet-truncated");
    // Cut after the third node: line 6 is missing.
    let cut: String = TET.lines().take(5).map(|l| format!("{l}\n")).collect();
    mesh_fails(
        &dir,
        "m.tetmesh",
        cut,
        &["m.tetmesh:6:", "unexpected end of file", "node 4 of 5"],
    );
    // Cut in the middle of a line.
    mesh_fails(
        &dir,
        "m.tetmesh",
        &TET[..TET.len() - 5],
        &["m.tetmesh:9:", "4 node indices"],
    );
    mesh_fails(&dir, "m.tetmesh", "", &["m.tetmesh:1:", "header"]);
}

#[test]
fn wrong_counts_name_the_line() {
    let dir = TempDir::new("tet-counts");
    mesh_fails(
        &dir,
        "m.tetmesh",
        TET.replace("5 2", "5 1"),
        &["m.tetmesh:9:", "declares"],
    );
    mesh_fails(
        &dir,
        "m.tetmesh",
        TET.replace("5 2", "6 2"),
        &["m.tetmesh:8:", "expected 3 coordinates"],
    );
    mesh_fails(
        &dir,
        "m.tetmesh",
        TET.replace("5 2", "5"),
        &["m.tetmesh:2:", "2 counts"],
    );
    mesh_fails(
        &dir,
        "m.tetmesh",
        TET.replace("1 2 3 4", "1 2 3 5"),
        &["m.tetmesh:9:", "node index 5 out of range"],
    );
    mesh_fails(
        &dir,
        "m.tetmesh",
        TET.replace("5 2", "5 0"),
        &["m.tetmesh", "at least one 4-node tetrahedron"],
    );
}

#[test]
fn bad_numbers_name_the_line_and_token() {
    let dir = TempDir::new("tet-numbers");
    for (bad, line, token) in [
        ("1 0 0\n0 1 0", "1.0.0 0 0\n0 1 0", "1.0.0"),
        ("0 0 1\n1 1 1", "0 0 nan\n1 1 1", "nan"),
        ("0 0 1\n1 1 1", "0 0 1e999\n1 1 1", "1e999"),
        ("0 1 2 3", "0 1 -2 3", "-2"),
        ("5 2", "5 two", "two"),
    ] {
        let text = TET.replacen(bad, line, 1);
        let n = text
            .lines()
            .position(|l| l.split(' ').any(|t| t == token))
            .unwrap()
            + 1;
        mesh_fails(
            &dir,
            "m.tetmesh",
            text,
            &[&format!("m.tetmesh:{n}:"), &format!("\"{token}\"")],
        );
    }
    // Not text at all.
    mesh_fails(
        &dir,
        "m.tetmesh",
        b"tetmesh 1\n\xff\xfe\x00\x01",
        &["m.tetmesh:2:", "UTF-8"],
    );
}

#[test]
fn huge_counts_are_refused_before_allocating() {
    let dir = TempDir::new("tet-huge");
    mesh_fails(
        &dir,
        "m.tetmesh",
        TET.replace("5 2", "99999999999 2"),
        &["m.tetmesh:2:", "exceeds the limit"],
    );
    mesh_fails(
        &dir,
        "m.tetmesh",
        TET.replace("5 2", "5 18446744073709551616"),
        &["m.tetmesh:2:", "18446744073709551616"],
    );
    // More nodes than the core addresses (u16 indices): a clear build error.
    let many = 70_000;
    let mut text = format!("tetmesh 1\n{many} 1\n");
    for i in 0..many {
        text.push_str(&format!("{} 0 0\n", i as f64 * 1e-3));
    }
    text.push_str("0 1 2 69999\n");
    dir.write("big.tetmesh", text);
    scene_fails(&dir, &mesh_scene("big.tetmesh"), &["scene.toml", "[mesh]"]);
}

const MSH2: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n$EndNodes\n$Elements\n2\n1 4 2 1 1 1 2 3 4\n2 4 2 1 1 2 3 4 5\n$EndElements\n";

const MSH41: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n$Elements\n1 1 1 1\n3 1 4 1\n1 1 2 3 4\n$EndElements\n";

#[test]
fn malformed_gmsh_files_name_the_file() {
    let dir = TempDir::new("msh");
    mesh_fails(
        &dir,
        "m.msh",
        &MSH2[..MSH2.find("2 4 2 1 1").unwrap()],
        &["m.msh:15:", "unexpected end of file", "element 2 of 2"],
    );
    mesh_fails(
        &dir,
        "m.msh",
        MSH2.replace("$Nodes\n5", "$Nodes\n6"),
        &["m.msh:"],
    );
    mesh_fails(
        &dir,
        "m.msh",
        MSH2.replace("2 1 0 0", "2 1 zero 0"),
        &["m.msh:7:", "\"zero\""],
    );
    mesh_fails(
        &dir,
        "m.msh",
        MSH2.replace("2 3 4 5\n", "2 3 4 9\n"),
        &["m.msh:", "node tag 9"],
    );
    mesh_fails(
        &dir,
        "m.msh",
        MSH2.replace("$Nodes\n5", "$Nodes\n99999999999"),
        &["m.msh:", "exceeds the limit"],
    );
    mesh_fails(&dir, "m.msh", &MSH41[..100], &["m.msh"]);
    mesh_fails(
        &dir,
        "m.msh",
        MSH41.replace("1 4 1 4\n3 1 0 4", "1 4 1 4\n3 1 0 99999999999"),
        &["m.msh"],
    );
}

#[test]
fn second_order_and_corrupt_binary_gmsh_files_are_explained() {
    let dir = TempDir::new("msh-order");
    // Two 10-node (second-order) tetrahedra: say to mesh first-order.
    let nodes: String = (1..=10).map(|i| format!("{i} {i} 0 {}\n", i % 3)).collect();
    let second_order = format!(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n10\n{nodes}$EndNodes\n$Elements\n2\n\
         1 11 2 0 1 1 2 3 4 5 6 7 8 9 10\n2 11 2 0 1 1 2 3 4 5 6 7 8 9 10\n$EndElements\n"
    );
    mesh_fails(
        &dir,
        "m.msh",
        second_order,
        &[
            "m.msh: expected at least one 4-node tetrahedron, found none",
            "2 of them are second- or higher-order tetrahedra",
            "mesh with first-order elements (Gmsh: `-order 1` or `Mesh.ElementOrder = 1`)",
        ],
    );
    // A binary MSH 4.1 file spoilt in its $Entities section: each parser
    // context once ("entity section: entity section: points" before).
    let mut b = b"$MeshFormat\n4.1 1 8\n".to_vec();
    b.extend(1i32.to_le_bytes());
    b.extend(b"\n$EndMeshFormat\n$Entities\n");
    for v in [3u64, 0, 0, 0] {
        b.extend(v.to_le_bytes());
    }
    b.extend(1i32.to_le_bytes());
    b.extend([0u8; 24]);
    b.extend(0u64.to_le_bytes());
    b.extend(b"garbage\n$EndEntities\n");
    dir.write("b.msh", &b);
    let e = fails(
        &dir,
        &["info", "b.msh"],
        &["b.msh: Gmsh MSH 4.1: entity section: points: point entity (2 of 3)"],
    );
    assert_eq!(e.matches("entity section").count(), 1, "{e}");
}

const VTK: &str = "# vtk DataFile Version 2.0\nm\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n";

#[test]
fn malformed_vtk_files_name_the_file() {
    let dir = TempDir::new("vtk");
    mesh_fails(&dir, "m.vtk", &VTK[..VTK.len() - 30], &["m.vtk"]);
    mesh_fails(
        &dir,
        "m.vtk",
        VTK.replace("POINTS 4", "POINTS 5"),
        &["m.vtk"],
    );
    mesh_fails(
        &dir,
        "m.vtk",
        VTK.replace("POINTS 4", "POINTS 99999999999"),
        &["m.vtk", "exceeds the limit"],
    );
    mesh_fails(
        &dir,
        "m.vtk",
        VTK.replace("4 0 1 2 3", "4 0 1 2 7"),
        &["m.vtk", "out of range"],
    );
    mesh_fails(&dir, "m.vtu", "<VTKFile type=\"Unstructured", &["m.vtu"]);
    mesh_fails(&dir, "m.vtu", b"\x00\x01garbage", &["m.vtu"]);
}

#[test]
fn missing_and_unknown_files_are_named() {
    let dir = TempDir::new("missing");
    scene_fails(
        &dir,
        &mesh_scene("nowhere/m.tetmesh"),
        &[
            "scene.toml: [mesh] file = \"nowhere/m.tetmesh\"",
            "cannot read",
        ],
    );
    // A scene in another folder: the mesh is reported as written and as
    // resolved against the scene's folder.
    fs::create_dir_all(dir.path("scenes")).unwrap();
    dir.write("scenes/s.toml", mesh_scene("meshes/m.tetmesh"));
    fails(
        &dir,
        &["run", "scenes/s.toml", "--out", "r.json"],
        &[
            "scenes/s.toml: [mesh] file = \"meshes/m.tetmesh\"",
            "scenes/meshes/m.tetmesh: cannot read",
        ],
    );
    fs::remove_dir_all(dir.path("scenes")).unwrap();
    dir.write("m.obj", "v 0 0 0\n");
    scene_fails(
        &dir,
        &mesh_scene("m.obj"),
        &[
            "scene.toml: [mesh] file = \"m.obj\"",
            "unknown mesh file extension \".obj\"",
        ],
    );
    fails(
        &dir,
        &["info", "absent.tetmesh"],
        &["absent.tetmesh", "cannot read"],
    );
    fails(
        &dir,
        &["run", "absent.toml", "--out", "r.json"],
        &["absent.toml: cannot read the scene file"],
    );
    // A folder instead of a file.
    fs::create_dir_all(dir.path("folder.toml")).unwrap();
    fails(
        &dir,
        &["run", "folder.toml", "--out", "r.json"],
        &["folder.toml: cannot read the scene file"],
    );
    // The result's folder does not exist.
    dir.write("m.tetmesh", TET);
    dir.write("scene.toml", mesh_scene("m.tetmesh"));
    fails(
        &dir,
        &["run", "scene.toml", "--out", "no/such/dir/r.json"],
        &["cannot write the result", "no/such/dir"],
    );
}

/// A valid generated-box scene to spoil.
const BOX: &str = "[mesh]\ngenerator = \"box\"\nsize = [1.0, 0.2, 0.2]\ncells = [4, 1, 1]\n\n[material]\nyoung = 1.0e6\npoisson = 0.3\n\n[solver]\nsteps = 3\ndt = 0.001\n\n[world]\ngravity = [0.0, 0.0, -9.81]\n\n[[fixed]]\nnodes = [0]\n\n[tool]\nnodes = [9]\nstiffness = 100.0\n\n[output]\nevery = 1\n";

#[test]
fn unknown_keys_are_named_with_their_table() {
    let dir = TempDir::new("keys");
    for (table, key) in [
        ("[mesh]", "cels"),
        ("[material]", "youngs"),
        ("[solver]", "time_step"),
        ("[world]", "gravty"),
        ("[[fixed]]", "node"),
        ("[tool]", "stifness"),
        ("[output]", "evry"),
    ] {
        let scene = BOX.replacen(table, &format!("{table}\n{key} = 1"), 1);
        scene_fails(&dir, &scene, &["scene.toml:", table, key]);
    }
    scene_fails(
        &dir,
        &format!("{BOX}\n[gound]\nnormal = [0.0, 0.0, 1.0]\n"),
        &["scene.toml:", "gound"],
    );
    // A misspelt table is an unknown table of the top level, not an
    // unknown key of the table above it.
    for (table, name, above) in [
        ("[solver]", "solvr", "[material]"),
        ("[output]", "outptu", "[tool]"),
    ] {
        let e = scene_fails(
            &dir,
            &BOX.replacen(table, &format!("[{name}]"), 1),
            &[
                "scene.toml:",
                &format!("(top level) unknown table `{name}`, expected one of `mesh`"),
            ],
        );
        assert!(!e.contains(above), "{e}");
        assert!(!e.contains("unknown field"), "{e}");
    }
}

#[test]
fn truncated_and_bad_scene_files_name_line_or_key() {
    let dir = TempDir::new("scene");
    // Cut inside `size = [1.0, 0.2, 0.2]`: a syntax error with line and column.
    let cut = &BOX[..BOX.find("0.2]").unwrap()];
    scene_fails(&dir, cut, &["scene.toml:3:"]);
    // Cut before `[solver]`: `steps` is missing.
    let cut = &BOX[..BOX.find("[solver]").unwrap()];
    scene_fails(&dir, cut, &["scene.toml: [solver]", "steps"]);
    scene_fails(&dir, "", &["scene.toml", "mesh"]);
    scene_fails(&dir, "\u{feff}\x00\x01", &["scene.toml"]);
    for (from, to, want) in [
        ("young = 1.0e6", "young = nan", "[material] young = NaN"),
        ("young = 1.0e6", "young = -inf", "[material] young = -inf"),
        ("young = 1.0e6", "young = 1e39", "[material] young = 1e39"),
        ("poisson = 0.3", "poisson = 0.5", "[material] poisson = 0.5"),
        ("poisson = 0.3", "poisson = \"0.3\"", "[material]"),
        ("dt = 0.001", "dt = 0.0", "[solver] dt = 0.0"),
        ("dt = 0.001", "dt = 1e-50", "[solver] dt = 1e-50"),
        ("steps = 3", "steps = -1", "[solver] steps = -1"),
        ("steps = 3", "steps = 3.5", "[solver]"),
        (
            "steps = 3",
            "steps = 3\ncg_iterations = 0",
            "[solver] cg_iterations = 0",
        ),
        ("every = 1", "every = 0", "[output] every = 0"),
        (
            "cells = [4, 1, 1]",
            "cells = [4, 0, 1]",
            "[mesh] cells = [4, 0, 1]",
        ),
        ("size = [1.0, 0.2, 0.2]", "size = [1.0, 0.2]", "[mesh]"),
        (
            "nodes = [0]",
            "nodes = [0, 99]",
            "[[fixed]] #1 nodes: node 99 does not exist",
        ),
        ("nodes = [9]", "nodes = [-9]", "[tool] nodes"),
        (
            "stiffness = 100.0",
            "stiffness = 0.0",
            "[tool] stiffness = 0.0",
        ),
        (
            "gravity = [0.0, 0.0, -9.81]",
            "gravity = [0.0, 0.0, inf]",
            "[world] gravity",
        ),
    ] {
        let scene = BOX.replacen(from, to, 1);
        assert_ne!(scene, BOX, "{from} not found");
        scene_fails(&dir, &scene, &["scene.toml", want]);
    }
}

#[test]
fn huge_counts_in_scene_files_are_refused() {
    let dir = TempDir::new("scene-huge");
    // Reserving the run's history for i64::MAX steps panicked ("capacity
    // overflow", exit 101) before this was checked.
    scene_fails(
        &dir,
        &BOX.replace("steps = 3", "steps = 9223372036854775807"),
        &["scene.toml: [solver] steps = 9223372036854775807: expected"],
    );
    scene_fails(
        &dir,
        &BOX.replace("steps = 3", "steps = 9223372036854775808"),
        &["scene.toml:", "[solver]"],
    );
    for cells in [
        "[65535, 65535, 65535]",
        "[65535, 1, 1]",
        "[70000, 1, 1]",
        "[9223372036854775807, 1, 1]",
    ] {
        scene_fails(
            &dir,
            &BOX.replace("cells = [4, 1, 1]", &format!("cells = {cells}")),
            &[&format!(
                "scene.toml: [mesh] cells = {cells}: expected at most 65536 nodes in all"
            )],
        );
    }
    scene_fails(
        &dir,
        &BOX.replace("every = 1", "every = 99999999999999999999"),
        &["scene.toml:", "[output]"],
    );
}

#[test]
fn a_run_that_fails_midway_writes_no_result() {
    let dir = TempDir::new("midway");
    // A force no f32 body takes: the run diverges at its first step. The
    // VTK frames written so far stay (the series is readable as it grows),
    // the result file does not appear.
    let scene = format!(
        "{}\n[[force]]\nnodes = [5]\ntotal = [3.0e38, 0.0, 0.0]\n",
        BOX.replace("young = 1.0e6", "young = 1.0e6\ndensity = 1.0e-9")
    );
    dir.write("scene.toml", &scene);
    let o = corofem(
        &["run", "scene.toml", "--out", "result.json", "--quiet"],
        &dir.0,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("scene.toml: diverged at step 1 of 3"), "{err}");
    assert_eq!(dir.files(), vec!["scene.toml"]);
}
