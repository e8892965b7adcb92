//! The messages a newcomer meets first: each says what is wrong with the
//! key, the part of the body and the number as the scene or mesh file
//! wrote them, and `info` and `run` agree on a mesh.

use std::fs;
use std::process::Output;

use serde_json::Value;

use crate::common::{corofem, TempDir};

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Runs `scene` as `scene.toml` in `dir`; returns the output.
fn run(dir: &TempDir, scene: &str, quiet: bool) -> Output {
    dir.write("scene.toml", scene);
    let mut args = vec!["run", "scene.toml", "--out", "result.json"];
    if quiet {
        args.push("--quiet");
    }
    corofem(&args, &dir.0)
}

/// Runs `scene`, which must fail with exit status 1; returns stderr.
fn fails(dir: &TempDir, scene: &str) -> String {
    let o = run(dir, scene, true);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(!dir.path("result.json").exists());
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A 5 × 1 × 1-cell beam, clamped at x = 0 unless `fixed` says otherwise.
fn beam(solver: &str, rest: &str) -> String {
    format!(
        "[mesh]\ngenerator = \"box\"\nsize = [1.0, 0.2, 0.2]\ncells = [5, 1, 1]\n\
         [solver]\n{solver}\n{rest}"
    )
}

const CLAMPED: &str = "[[fixed]]\nbox = { min = [-1.0, -1.0, -1.0], max = [1.0e-6, 1.0, 1.0] }\n";

#[test]
fn a_probe_inside_the_body_is_named_as_the_scene_numbers_it() {
    let dir = TempDir::new("probe-inside");
    // The first probe is well away; the second holds the beam's middle.
    let e = fails(
        &dir,
        &beam(
            "steps = 5",
            "[[probe]]\nradius = 0.05\nposition = [0.5, 0.1, 2.0]\n\
             [[probe]]\nradius = 0.2\nposition = [0.5, 0.1, 0.1]\n",
        ),
    );
    assert!(
        e.contains(
            "scene.toml: [[probe]] #2 starts inside the body at step 1 (t = 0.001 s): node "
        ),
        "{e}"
    );
    assert!(e.contains("move its `position`"), "{e}");
    assert!(!e.contains("diverged"), "{e}");
    assert!(!e.contains("probe 1 "), "{e}");
}

#[test]
fn a_probe_wholly_inside_the_body_is_named_as_the_scene_numbers_it() {
    let dir = TempDir::new("probe-wholly-inside");
    // In the middle of a 0.2 m cell, 0.17 m from its corners.
    let e = fails(
        &dir,
        &beam(
            "steps = 5",
            "[[probe]]\nradius = 0.02\nposition = [0.5, 0.1, 0.1]\n",
        ),
    );
    assert!(
        e.contains(
            "scene.toml: [[probe]] #1 starts inside the body at step 1 (t = 0.001 s): \
             it lies inside the body; move its `position`"
        ),
        "{e}"
    );
}

#[test]
fn a_body_below_the_ground_is_refused_with_the_offset_that_clears_it() {
    let dir = TempDir::new("below-ground");
    // The beam spans z in [0, 0.2]: a plane at 0.05 cuts it.
    let e = fails(
        &dir,
        &beam(
            "steps = 5",
            "[world]\nground = { normal = [0.0, 0.0, 1.0], offset = 0.05 }\n",
        ),
    );
    assert!(
        e.contains("scene.toml: the body starts below [world] ground: node 0 is 5.000e-2 m below"),
        "{e}"
    );
    assert!(e.contains("`offset` to at most 0.000000e0"), "{e}");
    assert!(!e.contains("diverged"), "{e}");
}

#[test]
fn values_beyond_f32_are_named_as_such() {
    let dir = TempDir::new("f32-range");
    let beyond = "within f32's range (at most 3.4e38 in magnitude; the solver computes in f32)";
    for (scene, want) in [
        (
            beam("steps = 1", "[material]\nyoung = 1e300\n"),
            format!("scene.toml: [material] young = 1e300: expected young >= 0 (Pa) {beyond}"),
        ),
        (
            beam("steps = 1", "[material]\ndensity = 1e39\n"),
            format!(
                "scene.toml: [material] density = 1e39: expected density > 0 (kg/m^3) {beyond}"
            ),
        ),
        (
            beam("steps = 1\ndt = 1e300", ""),
            format!("scene.toml: [solver] dt = 1e300: expected a time step > 0 (s) {beyond}"),
        ),
        (
            beam("steps = 1\ndt = 1e-60", ""),
            "scene.toml: [solver] dt = 1e-60: expected a time step > 0 (s) that f32 does not round to 0"
                .to_owned(),
        ),
        (
            "[mesh]\ngenerator = \"box\"\nsize = [1e300, 1.0, 1.0]\ncells = [1, 1, 1]\n[solver]\nsteps = 1\n"
                .to_owned(),
            format!(
                "scene.toml: [mesh] size = [1e300, 1.0, 1.0]: expected three lengths > 0 (m) {beyond}"
            ),
        ),
        (
            beam("steps = 1", "[world]\ngravity = [0.0, 0.0, -1e40]\n"),
            format!("scene.toml: [world] gravity = [0.0, 0.0, -1e40]: expected three numbers {beyond}"),
        ),
    ] {
        let e = fails(&dir, &scene);
        assert!(e.contains(&want), "want {want}\ngot {e}");
    }
    // Negative values keep their own message.
    let e = fails(&dir, &beam("steps = 1", "[material]\nyoung = -1.0\n"));
    assert!(
        e.contains("[material] young = -1.0: expected young >= 0 (Pa)\n"),
        "{e}"
    );
}

/// A .tetmesh of one tetrahedron whose fourth node is at `top`.
fn one_tet(top: &str) -> String {
    format!("tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1 0\n{top}\n0 1 2 3\n")
}

fn mesh_scene() -> String {
    "[mesh]\nfile = \"m.tetmesh\"\n[solver]\nsteps = 2\n".to_owned()
}

/// `info m.tetmesh` and a run of it give the same reason `why`; returns
/// the run's message.
fn info_and_run_reject(dir: &TempDir, why: &str) -> String {
    let info = text(&corofem(&["info", "m.tetmesh"], &dir.0));
    assert!(
        info.contains(&format!("corofem run    rejects the mesh: {why}")),
        "{info}"
    );
    let e = fails(dir, &mesh_scene());
    assert!(
        e.contains(&format!("scene.toml: [mesh] file = \"m.tetmesh\": {why}")),
        "{e}"
    );
    e
}

#[test]
fn info_and_run_agree_on_a_flat_sliver() {
    let dir = TempDir::new("sliver");
    dir.write("m.tetmesh", one_tet("0 0 1e-30"));
    let o = corofem(&["info", "m.tetmesh"], &dir.0);
    assert!(o.status.success(), "{}", text(&o));
    let info = text(&o);
    assert!(info.contains("1 degenerate"), "{info}");
    info_and_run_reject(
        &dir,
        "tetrahedron 0 is flat: its volume 1.667e-31 is 5.9e-32 of its longest edge \
         (1.414e0) cubed, and the solver needs more than 1e-12",
    );
    // A usable tetrahedron: info says so, run runs it.
    dir.write("m.tetmesh", one_tet("0 0 1"));
    let info = text(&corofem(&["info", "m.tetmesh"], &dir.0));
    assert!(info.contains("corofem run    usable"), "{info}");
    assert!(run(&dir, &mesh_scene(), true).status.success());
}

#[test]
fn info_and_run_agree_on_a_coordinate_beyond_f32() {
    let dir = TempDir::new("coordinate");
    dir.write("m.tetmesh", one_tet("0 0 1e39"));
    let e = info_and_run_reject(
        &dir,
        "node 3 has z = 1e39, beyond f32's range (at most 3.4e38 in magnitude after \
         [mesh] scale; the solver computes in f32)",
    );
    assert!(!e.contains("NaN"), "{e}");
    // The test is on the scaled coordinate: 1e37 at scale 100 is 1e39.
    dir.write("m.tetmesh", one_tet("0 0 1e37"));
    let e = fails(
        &dir,
        &mesh_scene().replace("[solver]", "scale = 100.0\n[solver]"),
    );
    assert!(e.contains("node 3 has z = 1e37, beyond f32's range"), "{e}");
}

#[test]
fn a_static_solve_held_by_one_or_two_nodes_says_the_body_can_turn() {
    let dir = TempDir::new("static-held");
    for (fixed, held) in [
        ("nodes = [0]", "1 node (node 0)"),
        ("nodes = [0, 7]", "2 nodes (nodes 0 and 7)"),
        // Three nodes along the bottom edge: one line.
        ("nodes = [0, 1, 2]", "3 nodes, all on one line"),
    ] {
        let e = fails(
            &dir,
            &beam("static = true", &format!("[[fixed]]\n{fixed}\n")),
        );
        assert!(
            e.contains(&format!(
                "scene.toml: [solver] static = true: the body is held by {held} ([[fixed]] and \
                 [tool]), which leaves it free to turn about them"
            )),
            "{e}"
        );
        assert!(
            e.contains("Hold at least 3 nodes that are not on one line"),
            "{e}"
        );
        assert!(!e.contains("diverged"), "{e}");
    }
}

#[test]
fn a_static_solve_says_converged_only_when_the_force_is_small() {
    let dir = TempDir::new("static-converged");
    // The default newton_tolerance (1e-5) is below this beam's f32 floor:
    // the updates stop moving it first.
    let o = run(&dir, &beam("static = true", CLAMPED), false);
    assert!(o.status.success(), "{}", text(&o));
    let r: Value =
        serde_json::from_str(&fs::read_to_string(dir.path("result.json")).unwrap()).unwrap();
    let st = &r["static"];
    let force = st["force"].as_f64().unwrap();
    let tolerance = st["tolerance"].as_f64().unwrap();
    assert_eq!(st["met"], "update", "{st}");
    assert!(force > tolerance, "{st}");
    assert_eq!(st["converged"], false, "{st}");
    let said = text(&o);
    assert!(
        said.contains("Newton iterations, the shape converged (last update "),
        "{said}"
    );
    assert!(said.contains("f32's round-off floor"), "{said}");
    assert!(!said.contains("converged: out-of-balance"), "{said}");
    // With a tolerance the force reaches, it is converged, and says by how much.
    let o = run(
        &dir,
        &beam("static = true\nnewton_tolerance = 1e-2", CLAMPED),
        false,
    );
    assert!(o.status.success(), "{}", text(&o));
    let r: Value =
        serde_json::from_str(&fs::read_to_string(dir.path("result.json")).unwrap()).unwrap();
    let st = &r["static"];
    assert_eq!(st["converged"], true, "{st}");
    assert!(st["force"].as_f64().unwrap() <= 1e-2, "{st}");
    let said = text(&o);
    assert!(
        said.contains("Newton iterations, converged: out-of-balance force "),
        "{said}"
    );
    assert!(
        said.contains("of the load (newton_tolerance 1e-2)"),
        "{said}"
    );
}

#[test]
fn a_truncated_vtk_file_says_it_ends_early() {
    let dir = TempDir::new("vtk-truncated");
    let whole =
        "# vtk DataFile Version 2.0\nm\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n\
                 0 0 0\n1 0 0\n0 1 0\n0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n";
    dir.write("m.vtk", &whole[..whole.find("0 1 0").unwrap()]);
    let o = corofem(&["info", "m.vtk"], &dir.0);
    assert_eq!(o.status.code(), Some(1));
    let e = text(&o);
    assert!(e.contains("m.vtk"), "{e}");
    assert!(e.contains("the file ends early"), "{e}");
    assert!(!e.contains("Complete"), "{e}");
}

#[test]
fn a_missing_required_key_names_its_table() {
    let dir = TempDir::new("missing-key");
    for (rest, want) in [
        (
            "[tool]\nnodes = [1]\n",
            "scene.toml:7:1: [tool]: missing key `stiffness`, which has no default",
        ),
        (
            "[[probe]]\nradius = 0.1\nposition = [0, 0, 5]\n[[probe]]\nposition = [0, 0, 1]\n",
            "scene.toml:10:1: [[probe]] #2: missing key `radius`, which has no default",
        ),
        (
            "[[force]]\nnodes = [1]\n",
            "scene.toml:7:1: [[force]] #1: missing key `total`",
        ),
        (
            "[world]\nground = { offset = 1.0 }\n",
            "scene.toml:8:10: [world] ground: missing key `normal`",
        ),
    ] {
        let e = fails(&dir, &beam("steps = 2", rest));
        assert!(e.contains(want), "want {want}\ngot {e}");
        assert!(!e.contains("(top level)"), "{e}");
    }
}

#[test]
fn vtk_frames_are_capped_with_a_note() {
    let dir = TempDir::new("vtk-cap");
    // 20,000 steps recorded every step: 20,001 records, written as every
    // 3rd, 6,667 frames.
    let o = corofem(
        &[
            "run",
            "scene.toml",
            "--out",
            "result.json",
            "--vtk",
            "frames",
        ],
        &{
            dir.write(
                "scene.toml",
                beam(
                    "steps = 20000\ndt = 1e-4",
                    &format!("{CLAMPED}[output]\nevery = 1\n"),
                ),
            );
            dir.0.clone()
        },
    );
    assert!(o.status.success(), "{}", text(&o));
    let said = text(&o);
    assert!(
        said.contains(
            "note: --vtk: the run records up to 20,002 history entries ([solver] steps / \
             [output] every); writing a VTK frame every 3 entries, at most 10,000 frames"
        ),
        "{said}"
    );
    let frames = fs::read_dir(dir.path("frames"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "vtu"))
        })
        .count();
    assert_eq!(frames, 6_667);
    assert!(said.contains("vtk        6667 frames in frames"), "{said}");
}

#[test]
fn one_tetrahedron_is_one_tet() {
    let dir = TempDir::new("one-tet");
    dir.write("m.tetmesh", one_tet("0 0 1"));
    let o = run(&dir, &mesh_scene(), false);
    assert!(o.status.success(), "{}", text(&o));
    let said = text(&o);
    assert!(said.contains("4 nodes, 1 tet, m.tetmesh)"), "{said}");
    assert!(!said.contains("1 tets"), "{said}");
}

#[test]
fn run_help_lists_every_key_with_its_default() {
    let o = corofem(&["run", "--help"], &TempDir::new("help").0);
    assert!(o.status.success());
    let help = String::from_utf8_lossy(&o.stdout);
    let keys = corofem_cli::scene_file::keys();
    assert!(keys.len() > 50);
    for k in &keys {
        let line = format!("  {} = {}", k.key, k.default);
        assert!(help.contains(&line), "{line:?} missing from run --help");
    }
    for table in [
        "[mesh]",
        "[solver]",
        "[world]",
        "[[fixed]]",
        "[tool]",
        "[[probe]]",
        "[output]",
    ] {
        assert!(help.contains(&format!("\n{table}\n")), "{table} heading");
    }
}

#[test]
fn plot_draws_each_quantity_of_the_history() {
    let dir = TempDir::new("plot");
    let scene = beam(
        "steps = 60\ndt = 0.001",
        &format!(
            "{CLAMPED}[world]\nground = {{ normal = [0, 0, 1], offset = -0.05 }}\n\
             [tool]\nnodes = [5]\nstiffness = 100.0\npath = [[0, 0, 0, 0], [0.06, 0, 0, 0.01]]\n\
             [[probe]]\nradius = 0.05\nposition = [1.0, 0.2, 0.3]\n\
             path = [[0, 0, 0, 0], [0.06, 0, 0, -0.1]]\n[output]\nevery = 5\n"
        ),
    );
    assert!(run(&dir, &scene, true).status.success());
    let o = corofem(&["plot", "result.json"], &dir.0);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("wrote result.svg"), "{}", text(&o));
    let svg = fs::read_to_string(dir.path("result.svg")).unwrap();
    assert!(svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""));
    assert!(svg.ends_with("</svg>\n"));
    let r: Value =
        serde_json::from_str(&fs::read_to_string(dir.path("result.json")).unwrap()).unwrap();
    let records = r["history"].as_array().unwrap().len();
    assert_eq!(records, 13);
    // One curve per quantity, each with a point per record.
    let curves: Vec<&str> = svg
        .lines()
        .filter(|l| l.starts_with("<polyline class=\"series\""))
        .collect();
    assert_eq!(curves.len(), 7, "{svg}");
    for c in &curves {
        let points = c
            .split("points=\"")
            .nth(1)
            .unwrap()
            .trim_end_matches("\"/>");
        assert_eq!(points.split(' ').count(), records, "{c}");
    }
    for name in [
        "kinetic_energy",
        "elastic_energy",
        "|support_force|",
        "|tool_force|",
        "|[[probe]] #1|",
        "contacts",
        "cg_iterations",
        "energy (J)",
        "force (N)",
        "t (s)",
    ] {
        assert!(svg.contains(&format!(">{name}<")), "{name} missing");
    }
    // The energy panel's curves are where their values say: the kinetic
    // energy's highest point is the record with the most kinetic energy.
    let ke: Vec<f64> = r["history"]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| h["kinetic_energy"].as_f64().unwrap())
        .collect();
    let ys: Vec<f64> = curves[0]
        .split("points=\"")
        .nth(1)
        .unwrap()
        .trim_end_matches("\"/>")
        .split(' ')
        .map(|p| p.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    let top = |v: &[f64], better: fn(f64, f64) -> bool| {
        (0..v.len()).fold(0, |b, i| if better(v[i], v[b]) { i } else { b })
    };
    assert_eq!(top(&ke, |a, b| a > b), top(&ys, |a, b| a < b));
    // --out, and a file that is not a result.
    let o = corofem(&["plot", "result.json", "--out", "p.svg"], &dir.0);
    assert!(o.status.success() && dir.path("p.svg").exists());
    dir.write("other.json", "{\"format\": \"something else\"}");
    let o = corofem(&["plot", "other.json"], &dir.0);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o).contains("other.json: format = \"something else\": expected \"corofem-result 1\""),
        "{}",
        text(&o)
    );
    assert!(!dir.path("other.svg").exists());
}
