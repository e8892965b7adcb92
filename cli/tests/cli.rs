//! Runs the built `corofem` binary on small generated-mesh scenes and checks
//! the result files, the error messages and the exit codes.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

use crate::common;
use common::{corofem, TempDir, BIN};

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `scene.toml` in `dir` with `--out result.json --quiet`.
fn run_scene(dir: &TempDir, scene: &str) -> Output {
    dir.write("scene.toml", scene);
    corofem(
        &["run", "scene.toml", "--out", "result.json", "--quiet"],
        &dir.0,
    )
}

fn run_ok(dir: &TempDir, scene: &str) -> Value {
    let o = run_scene(dir, scene);
    assert!(o.status.success(), "run failed: {}", stderr(&o));
    serde_json::from_str(&fs::read_to_string(dir.path("result.json")).unwrap()).unwrap()
}

fn run_err(dir: &TempDir, scene: &str) -> String {
    let o = run_scene(dir, scene);
    assert!(!o.status.success(), "run should fail");
    assert_eq!(o.status.code(), Some(1));
    assert!(
        !dir.path("result.json").exists(),
        "a failed run left a result file"
    );
    assert_eq!(
        dir.files(),
        vec!["scene.toml"],
        "a failed run left files behind"
    );
    stderr(&o)
}

/// A 1 × 0.2 × 0.2 m beam of 5 × 1 × 1 cells (24 nodes, 30 tets).
const BEAM: &str = r#"
[mesh]
generator = "box"
size = [1.0, 0.2, 0.2]
cells = [5, 1, 1]
tets_per_cell = 6

[material]
young = 1.0e6
poisson = 0.3
density = 1000.0
"#;

const DYNAMIC: &str = r#"
[solver]
method = "qr"
dt = 0.001
steps = 25
cg_iterations = 10
rayleigh_mass = 1.0

[world]
gravity = [0.0, 0.0, -9.81]
ground = { normal = [0.0, 0.0, 1.0], offset = -0.5 }

[[fixed]]
box = { min = [-1.0, -1.0, -1.0], max = [1.0e-6, 1.0, 1.0] }

[[force]]
nodes = [5, 11]
total = [0.0, 0.0, -2.0]

[initial]
velocity = [0.0, 0.1, 0.0]

[[material_change]]
step = 10
young = 2.0e6

[output]
every = 10
"#;

fn vec3(v: &Value) -> [f64; 3] {
    let a = v.as_array().expect("a vector");
    assert_eq!(a.len(), 3);
    [0, 1, 2].map(|k| a[k].as_f64().expect("a number"))
}

#[test]
fn result_has_every_key_of_the_format() {
    let dir = TempDir::new("keys");
    let r = run_ok(&dir, &format!("{BEAM}{DYNAMIC}"));
    assert_eq!(r["format"], "corofem-result 1");
    assert_eq!(r["scene"], "scene.toml");
    assert_eq!(r["mesh"]["nodes"], 24);
    assert_eq!(r["mesh"]["tets"], 30);
    assert_eq!(r["method"], "qr");
    assert_eq!(r["steps"], 25);
    for k in ["ms_per_step_median", "ms_per_step_min", "total_s"] {
        assert!(r["timing"][k].as_f64().unwrap() >= 0.0, "timing.{k}");
    }
    let fin = &r["final"];
    assert_eq!(fin["positions"].as_array().unwrap().len(), 24);
    assert_eq!(fin["velocities"].as_array().unwrap().len(), 24);
    for p in fin["positions"].as_array().unwrap() {
        vec3(p);
    }
    assert_eq!(fin["inverted"], 0);
    let history = r["history"].as_array().unwrap();
    let steps: Vec<u64> = history
        .iter()
        .map(|h| h["step"].as_u64().unwrap())
        .collect();
    assert_eq!(steps, vec![0, 10, 20, 25], "step 0, every 10, and the last");
    for h in history {
        let keys: Vec<&str> = h.as_object().unwrap().keys().map(String::as_str).collect();
        assert_eq!(
            keys.len(),
            13,
            "exactly the format's keys in a dynamic record: {keys:?}"
        );
        for k in ["t", "kinetic_energy", "elastic_energy", "cg_residual"] {
            assert!(h[k].as_f64().unwrap().is_finite(), "{k}");
        }
        for k in [
            "momentum",
            "angular_momentum",
            "tool_force",
            "support_force",
        ] {
            vec3(&h[k]);
        }
        // No [[probe]]: an empty list.
        assert_eq!(h["probe_forces"].as_array().unwrap().len(), 0);
        h["contacts"].as_u64().unwrap();
        h["inverted"].as_u64().unwrap();
        h["cg_iterations"].as_u64().unwrap();
    }
    assert_eq!(history[0]["t"], 0.0);
    assert!(
        history[0]["kinetic_energy"].as_f64().unwrap() > 0.0,
        "initial velocity"
    );
    assert_eq!(history[1]["t"], 0.01);
    assert_eq!(history[3]["t"], 0.025);
    // At most cg_iterations (CG may stop at its round-off floor).
    let cg = history[3]["cg_iterations"].as_u64().unwrap();
    assert!((1..=10).contains(&cg), "{cg}");
    // The clamped end did not move.
    let p0 = vec3(&fin["positions"][0]);
    assert_eq!(p0, [0.0, 0.0, 0.0]);
    // No temporary file is left next to the result.
    assert_eq!(dir.files(), vec!["result.json", "scene.toml"]);
}

#[test]
fn unknown_key_fails_and_names_it() {
    let dir = TempDir::new("unknown");
    let e = run_err(
        &dir,
        &format!("{BEAM}[solver]\nsteps = 5\nrayleigh_mas = 1.0\n"),
    );
    assert!(e.contains("rayleigh_mas"), "{e}");
    assert!(e.contains("scene.toml"), "{e}");
    assert!(e.contains("[solver]"), "{e}");

    let e = run_err(
        &dir,
        &format!("{BEAM}[solver]\nsteps = 5\n[wrold]\ngravity = [0.0, 0.0, 0.0]\n"),
    );
    assert!(e.contains("wrold"), "{e}");
}

#[test]
fn bad_values_name_file_key_and_expectation() {
    let dir = TempDir::new("badvalue");
    let poisson = BEAM.replace("poisson = 0.3", "poisson = 0.6");
    let e = run_err(&dir, &format!("{poisson}[solver]\nsteps = 5\n"));
    assert!(
        e.contains("scene.toml: [material] poisson = 0.6: expected 0 <= poisson < 0.5"),
        "{e}"
    );
    let e = run_err(&dir, &format!("{BEAM}[solver]\nsteps = 5\ndt = -0.001\n"));
    assert!(
        e.contains("scene.toml: [solver] dt = -0.001: expected"),
        "{e}"
    );
    let e = run_err(
        &dir,
        &format!("{BEAM}[solver]\nsteps = 5\n[[fixed]]\nnodes = [3, 999]\n"),
    );
    assert!(
        e.contains("scene.toml: [[fixed]] #1 nodes: node 999 does not exist"),
        "{e}"
    );
    let e = run_err(
        &dir,
        &format!("{BEAM}[solver]\nsteps = 5\nmethod = \"svd\"\n"),
    );
    assert!(
        e.contains("[solver] method = \"svd\": expected one of"),
        "{e}"
    );
    // A wrong type is reported by the TOML parser with file, line and section.
    let e = run_err(&dir, &format!("{BEAM}[solver]\nsteps = \"many\"\n"));
    assert!(e.contains("scene.toml:"), "{e}");
    assert!(e.contains("[solver]"), "{e}");
    assert!(e.contains("steps = \"many\""), "{e}");
}

#[test]
fn missing_files_are_clear_errors() {
    let dir = TempDir::new("missing");
    let e = run_err(
        &dir,
        "[mesh]\nfile = \"meshes/nowhere.tetmesh\"\n[solver]\nsteps = 1\n",
    );
    assert!(
        e.contains("scene.toml: [mesh] file = \"meshes/nowhere.tetmesh\""),
        "{e}"
    );
    assert!(e.contains("nowhere.tetmesh"), "{e}");

    let o = corofem(&["run", "absent.toml", "--out", "r.json"], &dir.0);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("absent.toml: cannot read the scene file"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path("r.json").exists());
}

#[test]
fn diverging_run_names_the_step_and_writes_nothing() {
    let dir = TempDir::new("diverge");
    let e = run_err(
        &dir,
        &format!(
            "{BEAM}[solver]\nsteps = 50\n[world]\ngravity = [0.0, 0.0, 0.0]\n[[force]]\nnodes = [0]\ntotal = [3.0e38, 0.0, 0.0]\n"
        ),
    );
    assert!(e.contains("scene.toml: diverged at step "), "{e}");
    assert!(e.contains(" of 50 (t = "), "{e}");
}

#[test]
fn static_history_has_one_record_per_newton_iteration() {
    let dir = TempDir::new("static");
    let r = run_ok(
        &dir,
        &format!(
            "{BEAM}[solver]\nstatic = true\n[[fixed]]\nbox = {{ min = [-1.0, -1.0, -1.0], max = [1.0e-6, 1.0, 1.0] }}\n"
        ),
    );
    let history = r["history"].as_array().unwrap();
    assert!(!history.is_empty());
    assert_eq!(r["steps"].as_u64().unwrap() as usize, history.len());
    // Each stopping rule's value, and the one that was met; converged means
    // the final shape's out-of-balance force is within the tolerance.
    let st = &r["static"];
    let num = |k: &str| st[k].as_f64().unwrap_or_else(|| panic!("static.{k}: {st}"));
    assert_eq!(st["converged"], num("force") <= num("tolerance"), "{st}");
    match st["met"].as_str() {
        Some("force") => assert!(num("residual") <= num("tolerance"), "{st}"),
        Some("update") => {
            assert!(num("update") <= num("update_tolerance"), "{st}");
            assert!(num("cg_residual") <= num("cg_tolerance"), "{st}");
        }
        other => panic!("static.met {other:?}: {st}"),
    }
    for (i, h) in history.iter().enumerate() {
        assert_eq!(h["step"].as_u64().unwrap() as usize, i + 1);
        assert_eq!(h["kinetic_energy"], 0.0);
        assert!(h["newton_residual"].as_f64().is_some());
        assert!(h["newton_update"].as_f64().is_some());
        assert!(h["cg_iterations"].as_u64().unwrap() > 0 || i + 1 == history.len());
    }
    for v in r["final"]["velocities"].as_array().unwrap() {
        assert_eq!(vec3(v), [0.0; 3]);
    }
    // It sagged.
    let tip = vec3(&r["final"]["positions"][5]);
    assert!(tip[2] < -1.0e-3, "tip {tip:?}");
}

#[test]
fn a_static_solve_that_stops_short_says_so() {
    // Two CG iterations per Newton iteration: the updates are small, but
    // not from solved systems.
    let dir = TempDir::new("static-short");
    dir.write(
        "scene.toml",
        format!(
            "{BEAM}[solver]\nstatic = true\ncg_iterations = 2\nnewton_iterations = 3\n[[fixed]]\nbox = {{ min = [-1.0, -1.0, -1.0], max = [1.0e-6, 1.0, 1.0] }}\n"
        ),
    );
    let o = corofem(&["run", "scene.toml", "--out", "result.json"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
    let said = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
    assert!(
        said.contains("did NOT converge in 3 Newton iterations"),
        "{said}"
    );
    assert!(
        said.contains("\nstatic     3 Newton iterations, NOT converged: out-of-balance force "),
        "{said}"
    );
    assert!(said.contains("\nwall time  "), "{said}");
    let r: Value =
        serde_json::from_str(&fs::read_to_string(dir.path("result.json")).unwrap()).unwrap();
    assert_eq!(r["static"]["converged"], false);
    assert!(r["static"]["met"].is_null());
    assert_eq!(r["steps"], 3);
}

#[test]
fn tool_scene_reports_the_tool_force_until_release() {
    let dir = TempDir::new("tool");
    let r = run_ok(
        &dir,
        &format!(
            r#"{BEAM}
[solver]
dt = 0.001
steps = 40
cg_iterations = 10
[world]
gravity = [0.0, 0.0, 0.0]
[[fixed]]
box = {{ min = [-1.0, -1.0, -1.0], max = [1.0e-6, 1.0, 1.0] }}
[tool]
box = {{ min = [0.99, -1.0, -1.0], max = [1.01, 1.0, 1.0] }}
stiffness = 1.0e4
path = [[0.0, 0.0, 0.0, 0.0], [0.02, 0.0, 0.0, 0.1]]
release = 0.03
[output]
every = 5
"#
        ),
    );
    let history = r["history"].as_array().unwrap();
    let force = |step: u64| {
        let h = history.iter().find(|h| h["step"] == step).unwrap();
        vec3(&h["tool_force"])
    };
    assert_eq!(force(0), [0.0; 3]);
    // Pulled up: the body pulls the tool down.
    assert!(force(20)[2] < -1.0, "{:?}", force(20));
    // Released after 0.03 s.
    assert_eq!(force(40), [0.0; 3]);
}

#[test]
fn vtk_series_has_a_frame_per_history_record() {
    let dir = TempDir::new("vtk");
    dir.write("scene.toml", format!("{BEAM}{DYNAMIC}"));
    let o = corofem(
        &[
            "run",
            "scene.toml",
            "--out",
            "r.json",
            "--vtk",
            "frames",
            "-q",
        ],
        &dir.0,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let frames = fs::read_dir(dir.path("frames"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "vtu")
        })
        .count();
    assert_eq!(frames, 4);
    let pvd = fs::read_to_string(dir.path("frames/series.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 4);
}

/// An octahedron around the middle of `BEAM`, its tips 1 cm outside the
/// top and bottom faces.
const OCTAHEDRON: &str = "v 0.5 0.1 -0.01\nv 0.5 0.1 0.21\nv 0.4 0.1 0.1\nv 0.6 0.1 0.1\n\
                          v 0.5 0.02 0.1\nv 0.5 0.18 0.1\n\
                          f 1 4 5\nf 1 5 3\nf 1 3 6\nf 1 6 4\nf 2 5 4\nf 2 3 5\nf 2 6 3\nf 2 4 6\n";

#[test]
fn a_visual_surface_moves_with_the_body_and_beside_the_vtk_frames() {
    let dir = TempDir::new("visual");
    dir.write("octahedron.obj", OCTAHEDRON);
    let visual = "[visual]\nfile = \"octahedron.obj\"\n";
    dir.write("scene.toml", format!("{BEAM}{DYNAMIC}{visual}"));
    let o = corofem(
        &["run", "scene.toml", "--out", "r.json", "--vtk", "frames"],
        &dir.0,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let r: Value = serde_json::from_str(&fs::read_to_string(dir.path("r.json")).unwrap()).unwrap();
    let v = &r["visual"];
    assert_eq!(v["vertices"], 6);
    assert_eq!(v["triangles"], 8);
    assert_eq!(v["inside"], 4);
    assert_eq!(v["outside"], 2);
    // The tips lie 1 cm outside, to the f32 round-off of coordinates of
    // size 1 (a few 1e-8 m) and a square root.
    assert!(
        (v["max_distance"].as_f64().unwrap() - 0.01).abs() < 1e-6,
        "{v}"
    );
    // The default reach: half the mean edge length of the tetrahedra. Each
    // tetrahedron of a 0.2 m cube cut in six has 3 edges along the cube's,
    // 2 face diagonals and the cube's diagonal: a mean of 0.2 (3 + 2√2 +
    // √3) / 6 m; the f32 sums round within 1e-6.
    let reach = v["reach"].as_f64().unwrap();
    let mean = 0.2 * (3.0 + 2.0 * 2f64.sqrt() + 3f64.sqrt()) / 6.0;
    assert!(
        (reach - 0.5 * mean).abs() < 1e-6,
        "{reach} against {}",
        0.5 * mean
    );
    let p = v["final_positions"].as_array().unwrap();
    assert_eq!(p.len(), 6);
    // The body sagged: the surface went down with it, in file order (the
    // bottom tip first).
    let (bottom, top) = (vec3(&p[0]), vec3(&p[1]));
    assert!(bottom[2] < -0.01 && top[2] < 0.21, "{bottom:?} {top:?}");
    // …and kept its size: the tips, 0.22 m apart at rest, stay so to the
    // beam's strain under its own weight and 2 N (below 1e-2 at E = 1e6 Pa).
    let d = (0..3)
        .map(|k| (top[k] - bottom[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!((d - 0.22).abs() < 0.22e-2, "{bottom:?} {top:?}");
    let pvd = fs::read_to_string(dir.path("frames/surface.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 4);
    assert!(dir.path("frames/surface_000003.vtu").exists());
    let lines = summary_lines(&o);
    assert!(
        lines.iter().any(|l| l.starts_with(
            "surface    6 vertices, 8 triangles, 2 outside the tetrahedra (at most 1.00e-2 m"
        )),
        "{lines:#?}"
    );
    assert!(
        lines
            .iter()
            .any(|l| l.ends_with("4 surface frames beside them (open surface.pvd)")),
        "{lines:#?}"
    );

    // Without [visual], no `visual` key.
    let r = run_ok(&dir, &format!("{BEAM}{DYNAMIC}"));
    assert!(r.get("visual").is_none());
}

#[test]
fn a_bad_visual_surface_is_a_clear_error() {
    let dir = TempDir::new("visual-bad");
    let scene = |extra: &str| format!("{BEAM}[solver]\nsteps = 2\n[visual]\n{extra}");
    // Too far for the reach given, and in other units.
    dir.write("octahedron.obj", OCTAHEDRON);
    let e = run_err_keeping(&dir, &scene("file = \"octahedron.obj\"\nreach = 0.005\n"));
    assert!(
        e.contains("scene.toml: [visual] file = \"octahedron.obj\": vertex 0 at [0.5, 0.1, -0.01] lies farther than 0.005 m"),
        "{e}"
    );
    assert!(e.contains("Raise `reach`"), "{e}");
    let mm: String = OCTAHEDRON
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(xyz) => {
                let c: Vec<f64> = xyz
                    .split(' ')
                    .map(|x| x.parse::<f64>().unwrap() * 1e3)
                    .collect();
                format!("v {} {} {}\n", c[0], c[1], c[2])
            }
            None => format!("{l}\n"),
        })
        .collect();
    dir.write("mm.obj", &mm);
    let e = run_err_keeping(&dir, &scene("file = \"mm.obj\"\n"));
    assert!(e.contains("(reach = 0.5 mean edge lengths)"), "{e}");
    assert!(e.contains("in the mesh's units and place"), "{e}");
    // Files that are not surfaces.
    dir.write(
        "flat.obj",
        "v 0.5 0.1 0.1\nv 0.6 0.1 0.1\nv 0.7 0.1 0.1\nf 1 2 3\n",
    );
    let e = run_err_keeping(&dir, &scene("file = \"flat.obj\"\n"));
    assert!(e.contains("surface triangle 0 is degenerate"), "{e}");
    dir.write("empty.obj", "# nothing\n");
    let e = run_err_keeping(&dir, &scene("file = \"empty.obj\"\n"));
    assert!(
        e.contains("empty.obj: expected at least one triangle, found none"),
        "{e}"
    );
    let e = run_err_keeping(&dir, &scene("file = \"missing.stl\"\n"));
    assert!(e.contains("missing.stl: cannot read file"), "{e}");
    let e = run_err_keeping(&dir, &scene("file = \"octahedron.ply\"\n"));
    assert!(e.contains("(expected .obj or .stl)"), "{e}");
    // Keys.
    let e = run_err_keeping(&dir, &scene("file = \"octahedron.obj\"\nreach = -1.0\n"));
    assert!(
        e.contains("[visual] reach = -1.0: expected a distance >= 0"),
        "{e}"
    );
    let e = run_err_keeping(&dir, &scene("file = \"octahedron.obj\"\ncolour = 1\n"));
    assert!(e.contains("colour"), "{e}");
    let e = run_err_keeping(&dir, &scene("reach = 1.0\n"));
    assert!(e.contains("file"), "{e}");
}

/// Like `run_err`, in a folder that holds other files: the run fails with
/// exit code 1 and writes no result.
fn run_err_keeping(dir: &TempDir, scene: &str) -> String {
    let o = run_scene(dir, scene);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(!dir.path("result.json").exists());
    stderr(&o)
}

#[test]
fn stdout_and_default_destinations() {
    let dir = TempDir::new("dest");
    dir.write("beam.toml", format!("{BEAM}[solver]\nsteps = 3\n"));
    let o = corofem(&["run", "beam.toml", "--out", "-", "-q"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(r["steps"], 3);
    assert_eq!(dir.files(), vec!["beam.toml"]);

    // A missing output folder is reported before the run.
    let o = corofem(
        &["run", "beam.toml", "--out", "nowhere/r.json", "-q"],
        &dir.0,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("does not exist"), "{}", stderr(&o));

    // Without --out: <stem>.result.json in the current directory, and a summary.
    let o = corofem(&["run", "beam.toml"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.path("beam.result.json").exists());
    assert!(stderr(&o).contains("3 steps"), "{}", stderr(&o));
}

/// The summary's lines on stderr, from its first label (`scene`) on.
fn summary_lines(o: &Output) -> Vec<String> {
    let e = stderr(o);
    let lines: Vec<String> = e.lines().map(str::to_owned).collect();
    let first = lines
        .iter()
        .position(|l| l.starts_with("scene      "))
        .unwrap_or_else(|| panic!("no summary in:\n{e}"));
    lines[first..].to_vec()
}

#[test]
fn the_summary_is_an_aligned_block() {
    let dir = TempDir::new("summary");
    dir.write("scene.toml", format!("{BEAM}{DYNAMIC}"));
    let o = corofem(
        &["run", "scene.toml", "--out", "r.json", "--vtk", "frames"],
        &dir.0,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let lines = summary_lines(&o);
    let labels: Vec<&str> = lines.iter().map(|l| l[..11].trim_end()).collect();
    assert_eq!(
        labels,
        ["scene", "ran", "final", "result", "vtk"],
        "{lines:#?}"
    );
    for l in &lines {
        assert!(l.len() < 130, "a long summary line: {l}");
        // Values start in column 12, after the padded label.
        assert_eq!(&l[10..11], " ", "{l}");
        assert_ne!(&l[11..12], " ", "{l}");
    }
    assert!(
        lines[0].starts_with("scene      scene.toml (qr, 24 nodes, 30 tets, box 5x1x1 cells"),
        "{lines:#?}"
    );
    assert!(
        lines[1].starts_with("ran        25 steps of 0.001 s in "),
        "{lines:#?}"
    );
    assert!(lines[2].contains(" inverted (at most "), "{lines:#?}");
    assert_eq!(lines[3], "result     r.json");
    assert_eq!(lines[4], "vtk        4 frames in frames (open series.pvd)");
    // No tool, no tool line (it used to say "max |tool force| 0.0000 N").
    assert!(!stderr(&o).contains("tool"), "{}", stderr(&o));

    // With a tool: its largest force; the result on standard output.
    dir.write(
        "tool.toml",
        format!(
            "{BEAM}[solver]\nsteps = 5\n[tool]\nnodes = [5]\nstiffness = 100.0\npath = [[0.0, 0, 0, 0], [0.005, 0, 0, 0.01]]\n"
        ),
    );
    let o = corofem(&["run", "tool.toml", "--out", "-"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
    let lines = summary_lines(&o);
    let labels: Vec<&str> = lines.iter().map(|l| l[..11].trim_end()).collect();
    assert_eq!(
        labels,
        ["scene", "ran", "final", "tool", "result"],
        "{lines:#?}"
    );
    assert!(
        lines[3].starts_with("tool       max |force| "),
        "{lines:#?}"
    );
    assert!(lines[3].ends_with(" N"), "{lines:#?}");
    assert_eq!(lines[4], "result     standard output");
}

/// A tetmesh file with one tetrahedron, negatively oriented when `flip`.
fn one_tet(flip: bool) -> String {
    let tet = if flip { "0 2 1 3" } else { "0 1 2 3" };
    format!("tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n{tet}\n")
}

#[test]
fn mesh_paths_are_relative_to_the_scene_and_reorient_is_optional() {
    let dir = TempDir::new("relative");
    fs::create_dir_all(dir.path("scenes/meshes")).unwrap();
    dir.write("scenes/meshes/flipped.tetmesh", one_tet(true));
    let scene = "[mesh]\nfile = \"meshes/flipped.tetmesh\"\n[solver]\nsteps = 2\n[world]\ngravity = [0.0, 0.0, 0.0]\n";
    dir.write("scenes/s.toml", scene);
    // Run from the parent folder: the mesh is found next to the scene.
    let o = corofem(&["run", "scenes/s.toml", "--out", "r.json", "-q"], &dir.0);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains(
            "tetrahedron 0 is negatively oriented (set `reorient = true` in [mesh] to fix it)"
        ),
        "{e}"
    );
    // One hint, not the core's and the scene file's.
    assert_eq!(e.matches("reorient").count(), 1, "{e}");
    assert!(!e.contains("re-orientation"), "{e}");
    assert!(!dir.path("r.json").exists());

    dir.write(
        "scenes/s.toml",
        scene.replace("[solver]", "reorient = true\n[solver]"),
    );
    let o = corofem(&["run", "scenes/s.toml", "--out", "r.json", "-q"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn unused_nodes_are_dropped_with_a_note() {
    let dir = TempDir::new("unused");
    dir.write(
        "u.tetmesh",
        "tetmesh 1\n5 1\n0 0 0\n1 0 0\n0 1 0\n9 9 9\n0 0 1\n0 1 2 4\n",
    );
    dir.write(
        "u.toml",
        "[mesh]\nfile = \"u.tetmesh\"\n[solver]\nsteps = 2\n[output]\nevery = 1\n",
    );
    let o = corofem(&["run", "u.toml", "--out", "u.json"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("dropped 1 node that no tetrahedron uses"),
        "{}",
        stderr(&o)
    );
    let r: Value = serde_json::from_str(&fs::read_to_string(dir.path("u.json")).unwrap()).unwrap();
    assert_eq!(r["mesh"]["nodes"], 4);
    // Default dt 0.001, reported as written.
    assert_eq!(r["history"][2]["t"], 0.002);
}

#[test]
fn info_describes_a_mesh() {
    let dir = TempDir::new("info");
    dir.write("t.tetmesh", one_tet(true));
    let o = corofem(&["info", "t.tetmesh"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    for word in [
        "nodes          4 (0 unused)",
        "tetrahedra     1",
        "bounding box",
        "volume",
        "dihedral angle",
        "1 negatively oriented",
        "zero volume    0",
    ] {
        assert!(out.contains(word), "{word:?} missing in\n{out}");
    }
    // A flat tetrahedron has no orientation: it is degenerate.
    dir.write(
        "flat.tetmesh",
        "tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n0 1 2 3\n",
    );
    let o = corofem(&["info", "flat.tetmesh"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("orientation    1 degenerate (zero volume"),
        "{out}"
    );
    assert!(!out.contains("positively oriented"), "{out}");
    assert!(out.contains("zero volume    1"), "{out}");
    let o = corofem(&["info", "nothing.msh"], &dir.0);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("nothing.msh"), "{}", stderr(&o));
}

#[test]
fn info_describes_a_surface() {
    let dir = TempDir::new("info-surface");
    dir.write("octahedron.obj", OCTAHEDRON);
    let o = corofem(&["info", "octahedron.obj"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    for line in [
        "  vertices       6 (0 in no triangle)",
        "  triangles      8",
        "  bounding box   [0.4, 0.02, -0.01] .. [0.6, 0.18, 0.21]",
        "  edges          12 (closed, consistently wound)",
        "  surface        binds, if within reach of the tetrahedra ([visual])",
    ] {
        assert!(out.contains(line), "{line:?} missing in\n{out}");
    }
    // One triangle turned, one dropped, a degenerate one added.
    let bad = OCTAHEDRON
        .replace("f 1 4 5\n", "f 1 5 4\n")
        .replace("f 2 6 3\n", "f 2 2 3\n");
    dir.write("bad.obj", &bad);
    let o = corofem(&["info", "bad.obj"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("wound the same way twice"), "{out}");
    assert!(out.contains("on one triangle only"), "{out}");
    assert!(
        out.contains("refused by [visual]: surface triangle 6 is degenerate"),
        "{out}"
    );
    dir.write("empty.stl", "solid x\nendsolid x\n");
    let o = corofem(&["info", "empty.stl"], &dir.0);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("empty.stl"), "{}", stderr(&o));
}

#[test]
fn usage_errors_exit_with_2() {
    let dir = TempDir::new("usage");
    let o = corofem(&["run"], &dir.0);
    assert_eq!(o.status.code(), Some(2));
    let o = corofem(&["run", "--help"], &dir.0);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("reorient = false"));
}

/// Runs every shipped example scene that reads the third-party meshes
/// (`shared: true`) or every one that does not (`false`), from a copy so
/// that their results stay out of the source tree.
fn run_shipped_scenes(shared: bool) {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
    let dir = TempDir::new(if shared { "shipped-shared" } else { "shipped" });
    let mut names: Vec<PathBuf> = fs::read_dir(&scenes)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .filter(|p| fs::read_to_string(p).unwrap().contains("shared/meshes") == shared)
        .collect();
    names.sort();
    assert!(names.len() >= 4, "{names:?}");
    for scene in names {
        let out = dir.path("r.json");
        let o = Command::new(BIN)
            .args([
                "run",
                scene.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "-q",
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}: {}", scene.display(), stderr(&o));
        let r: Value = serde_json::from_str(&fs::read_to_string(&out).unwrap()).unwrap();
        assert_eq!(r["final"]["inverted"], 0, "{}", scene.display());
    }
}

/// The shipped example scenes on generated meshes.
#[test]
fn shipped_scenes_run() {
    run_shipped_scenes(false);
}

/// The shipped example scenes on the third-party meshes.
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn shipped_scenes_on_the_shared_meshes_run() {
    run_shipped_scenes(true);
}

/// The paper's claims on the shipped Figure 3 scenes: the rest-B element
/// turns the tetrahedron, the QR element hardly does.
#[test]
fn figure3_ghost_torque() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
    let dir = TempDir::new("figure3");
    let max_l = |name: &str| {
        let out = dir.path(&format!("{name}.json"));
        let o = Command::new(BIN)
            .args([
                "run",
                scenes.join(name).to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "-q",
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        let r: Value = serde_json::from_str(&fs::read_to_string(&out).unwrap()).unwrap();
        r["history"]
            .as_array()
            .unwrap()
            .iter()
            .map(|h| {
                let l = vec3(&h["angular_momentum"]);
                (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt()
            })
            .fold(0.0, f64::max)
    };
    let rest_b = max_l("figure3_tet.toml");
    let qr = max_l("figure3_tet_qr.toml");
    assert!(rest_b > 0.1, "qr-rest-b max |L| = {rest_b}");
    assert!(qr < rest_b / 20.0, "qr max |L| = {qr}, qr-rest-b {rest_b}");
}
