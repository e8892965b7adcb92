//! The scenes of `examples/haptic_loop.c`, run three ways: through the Rust
//! API, through the C functions called from Rust, and (when
//! `COROFEM_C_EXAMPLE` names the compiled C program, as `.ci/capi.sh` does)
//! by the C program itself. All three must give the same state hash.

use std::path::PathBuf;
use std::process::Command;

use corofem_capi::{Material, Settings, Stats, Status};
use corofem_core::{BoxMesh, BuildOptions};

mod common;

/// One scene of the C example, exactly as it builds it.
struct Def {
    nodes: Vec<[f32; 3]>,
    tets: Vec<[u32; 4]>,
    material: corofem_core::Material,
    settings: corofem_core::Settings,
    fixed: Vec<u32>,
    tip: Vec<u32>,
    stiffness: f32,
    pull: [f32; 3],
}

fn base_settings() -> corofem_core::Settings {
    // As the C example: QR and the paper's CG, 10 iterations, cold.
    corofem_core::Settings {
        method: corofem_core::Method::Qr,
        dt: 0.001,
        cg_iterations: 10,
        warm_start: false,
        preconditioner: corofem_core::Preconditioner::Mass,
        ..corofem_core::Settings::default()
    }
}

fn box_def() -> Def {
    let mesh = BoxMesh {
        size: [0.1, 0.02, 0.02],
        cells: [10, 2, 2],
        tets_per_cell: 6,
    };
    let mut nodes = vec![[0.0; 3]; mesh.node_count()];
    let mut tets = vec![[0; 4]; mesh.tet_count()];
    mesh.generate(&mut nodes, &mut tets).unwrap();
    Def {
        nodes,
        tets,
        material: corofem_core::Material {
            young: 1.0e5,
            poisson: 0.4,
            density: 1000.0,
        },
        settings: corofem_core::Settings {
            rayleigh_mass: 5.0,
            ..base_settings()
        },
        fixed: (0..9).map(|jk| 11 * jk).collect(),
        tip: (0..9).map(|jk| 11 * jk + 10).collect(),
        stiffness: 500.0,
        pull: [0.0, 0.0, -0.02],
    }
}

fn liver_path() -> Option<PathBuf> {
    common::shared_mesh("sofa_liver.tetmesh")
}

fn liver_def(path: &std::path::Path) -> Def {
    let mesh = corofem_io::read_mesh(path).unwrap();
    let (nodes, tets) = corofem_io::to_core(&mesh, 0.03);
    Def {
        nodes,
        tets,
        material: corofem_core::Material {
            young: 5.0e3,
            poisson: 0.45,
            density: 1000.0,
        },
        settings: corofem_core::Settings {
            rayleigh_mass: 1.0,
            rayleigh_stiffness: 0.01,
            gravity: [0.0, -9.81, 0.0],
            ..base_settings()
        },
        fixed: vec![3, 39, 64],
        tip: vec![80, 81, 78, 83, 82],
        stiffness: 2000.0,
        pull: [0.03, 0.02, 0.0],
    }
}

/// The tool path of the C example: a triangle wave 0 → 1 → 0 each second.
fn triangle(step: u32) -> f32 {
    let a = (step % 1000) as f32 / 1000.0;
    if a < 0.5 {
        2.0 * a
    } else {
        2.0 - 2.0 * a
    }
}

fn target(start: [f32; 3], pull: [f32; 3], step: u32) -> [f32; 3] {
    let a = triangle(step + 1);
    [
        start[0] + a * pull[0],
        start[1] + a * pull[1],
        start[2] + a * pull[2],
    ]
}

/// Through the Rust API: (hash, tool force).
fn run_rust(d: &Def, steps: u32) -> (u64, [f32; 3]) {
    let mut s = corofem_core::VecScene::with_capacity(d.nodes.len(), d.tets.len());
    s.build(&d.nodes, &d.tets, &d.material, BuildOptions::default())
        .unwrap();
    s.set_settings(d.settings).unwrap();
    s.fix_nodes(&d.fixed).unwrap();
    s.grab(&d.tip, d.stiffness).unwrap();
    let start = s.tool_target();
    let mut force = [0.0; 3];
    for i in 0..steps {
        // The liver's thinnest elements may invert under the pull; the QR
        // method pushes them back, so inversions are not an error here.
        let st = s.step_haptic(target(start, d.pull, i)).unwrap();
        force = st.tool_force;
    }
    (s.state_hash(), force)
}

/// `d`'s scene made through the C functions, in a heap buffer at an odd
/// address (which the handle must not outlive), its settings checked by
/// reading them back, its nodes fixed.
fn capi_scene(d: &Def) -> (Vec<u8>, *mut corofem_capi::SceneHandle) {
    let (n, t) = (d.nodes.len(), d.tets.len());
    let mut bytes = 0usize;
    // SAFETY (whole function): every pointer is a live local or a slice of
    // the stated length; the buffer outlives the handle.
    unsafe {
        assert_eq!(
            corofem_capi::corofem_scene_bytes(n, t, &mut bytes),
            Status::Ok
        );
        let mut buf = vec![0u8; bytes + 1];
        let mut h = std::ptr::null_mut();
        let ok =
            corofem_capi::corofem_scene_init(buf.as_mut_ptr().add(1).cast(), bytes, n, t, &mut h);
        assert_eq!(ok, Status::Ok);
        let mat = Material {
            young: d.material.young,
            poisson: d.material.poisson,
            density: d.material.density,
        };
        let st = corofem_capi::corofem_build(
            h,
            d.nodes.as_ptr().cast(),
            n,
            d.tets.as_ptr().cast(),
            t,
            &mat,
            0,
            std::ptr::null_mut(),
        );
        assert_eq!(st, Status::Ok);
        let mut set = std::mem::zeroed::<Settings>();
        assert_eq!(corofem_capi::corofem_settings_default(&mut set), Status::Ok);
        set.dt = d.settings.dt;
        set.cg_iterations = d.settings.cg_iterations;
        set.rayleigh_mass = d.settings.rayleigh_mass;
        set.rayleigh_stiffness = d.settings.rayleigh_stiffness;
        set.gravity = d.settings.gravity;
        set.warm_start = u32::from(d.settings.warm_start);
        // The C codes are the core's discriminants.
        set.method = d.settings.method as u32;
        set.preconditioner = d.settings.preconditioner as u32;
        assert_eq!(corofem_capi::corofem_set_settings(h, &set), Status::Ok);
        let mut back = std::mem::zeroed::<Settings>();
        assert_eq!(corofem_capi::corofem_get_settings(h, &mut back), Status::Ok);
        assert_eq!(back, set);
        let f = &d.fixed;
        assert_eq!(
            corofem_capi::corofem_fix_nodes(h, f.as_ptr(), f.len()),
            Status::Ok
        );
        (buf, h)
    }
}

/// Through the C functions, in a heap buffer at an odd address: (hash, tool force).
fn run_capi(d: &Def, steps: u32) -> (u64, [f32; 3]) {
    let (_buf, h) = capi_scene(d);
    // SAFETY (whole block): every pointer is a live local or a slice of
    // the stated length; `_buf` outlives the handle.
    unsafe {
        let g = &d.tip;
        assert_eq!(
            corofem_capi::corofem_grab(h, g.as_ptr(), g.len(), d.stiffness),
            Status::Ok
        );
        let mut start = [0.0f32; 3];
        assert_eq!(
            corofem_capi::corofem_tool_target(h, start.as_mut_ptr()),
            Status::Ok
        );
        let mut force = [0.0f32; 3];
        let mut stats = Stats::default();
        for i in 0..steps {
            let tg = target(start, d.pull, i);
            let st =
                corofem_capi::corofem_step_haptic(h, tg.as_ptr(), force.as_mut_ptr(), &mut stats);
            assert_eq!(st, Status::Ok);
        }
        assert_eq!(stats.steps, u64::from(steps));
        assert_eq!(stats.tool_force, force);
        let mut hash = 0u64;
        assert_eq!(corofem_capi::corofem_state_hash(h, &mut hash), Status::Ok);
        assert_eq!(corofem_capi::corofem_scene_deinit(h), Status::Ok);
        (hash, force)
    }
}

/// Runs the compiled C example, if `COROFEM_C_EXAMPLE` names it: its hash.
fn run_c(args: &[&str]) -> Option<u64> {
    let exe = std::env::var_os("COROFEM_C_EXAMPLE")?;
    let out = Command::new(&exe)
        .args(args)
        .output()
        .expect("C example runs");
    let text = String::from_utf8_lossy(&out.stdout);
    eprintln!("{text}");
    assert!(out.status.success(), "C example failed: {text}");
    let line = text.lines().find_map(|l| l.strip_prefix("hash "))?;
    Some(u64::from_str_radix(line.trim(), 16).expect("hex hash"))
}

const STEPS: u32 = 2000;

/// `--help` and `-h` print the usage (they used to be read as a mesh file
/// named `--help`); an unknown option is a usage error.
#[test]
fn c_example_help_prints_usage() {
    let Some(exe) = std::env::var_os("COROFEM_C_EXAMPLE") else {
        return;
    };
    for flag in ["--help", "-h"] {
        let out = Command::new(&exe)
            .arg(flag)
            .output()
            .expect("C example runs");
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{flag}: {text}");
        assert!(text.starts_with("usage: haptic_loop "), "{flag}: {text}");
    }
    let out = Command::new(&exe)
        .arg("--bogus")
        .output()
        .expect("C example runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stdout).contains("unknown option --bogus"));
}

#[test]
fn box_scene_same_hash_from_rust_and_c() {
    let d = box_def();
    let (rust, force) = run_rust(&d, STEPS);
    let (capi, cforce) = run_capi(&d, STEPS);
    println!("box: rust hash {rust:016x}, tool force {force:?} N");
    assert_eq!(rust, capi);
    assert_eq!(force, cforce);
    // The beam pulls the tool back up (towards +z) and the force is finite.
    assert!(force.iter().all(|f| f.is_finite()));
    if let Some(c) = run_c(&["box", &STEPS.to_string()]) {
        assert_eq!(c, rust, "C program hash {c:016x} vs Rust {rust:016x}");
    }
}

#[test]
fn liver_scene_same_hash_from_rust_and_c() {
    let Some(path) = liver_path() else { return };
    let d = liver_def(&path);
    let (rust, force) = run_rust(&d, STEPS);
    let (capi, cforce) = run_capi(&d, STEPS);
    println!("liver: rust hash {rust:016x}, tool force {force:?} N");
    assert_eq!(rust, capi);
    assert_eq!(force, cforce);
    assert!(force.iter().all(|f| f.is_finite()));
    let p = path.to_string_lossy().into_owned();
    if let Some(c) = run_c(&[&p, &STEPS.to_string()]) {
        assert_eq!(c, rust, "C program hash {c:016x} vs Rust {rust:016x}");
    }
}

/// The two-level preconditioner (3 iterations, warm start) through the C
/// API: the scene buffer holds its slots, and the bits are the Rust API's.
#[test]
fn liver_with_two_level_same_hash_from_rust_and_c() {
    let Some(path) = liver_path() else { return };
    let mut d = liver_def(&path);
    d.settings.preconditioner = corofem_core::Preconditioner::TwoLevel;
    d.settings.cg_iterations = 3;
    d.settings.warm_start = true;
    let (rust, force) = run_rust(&d, STEPS);
    let (capi, cforce) = run_capi(&d, STEPS);
    println!("liver, two-level: rust hash {rust:016x}, tool force {force:?} N");
    assert_eq!(rust, capi);
    assert_eq!(force, cforce);
    // Not the mass preconditioner's run: the setting reached the solver.
    let mass = run_rust(&liver_def(&path), STEPS).0;
    assert_ne!(rust, mass);
}

/// The probe scenes of the C example (`--probe`, `--friction`,
/// `--coupling`): a 1 cm sphere pressed into the body from above, slid and
/// lifted, instead of the tool; the body held by a tray, without gravity.
/// With the coupling the path is the device's and the sphere its proxy.
#[cfg(feature = "probe")]
mod probe_scene {
    use super::*;

    use corofem_capi::ProbesHandle;
    use corofem_core::{Friction, Probe};

    const RADIUS: f32 = 0.01;
    /// How far below the pressed node the sphere's lowest point goes (m).
    const DEPTH: f32 = 0.01;

    /// The axis against gravity and the pressed node, as the C example
    /// chooses them: the box's node 84, or the liver's first node of the
    /// largest height.
    fn pressed(d: &Def, is_box: bool) -> (usize, usize) {
        if is_box {
            return (2, 84);
        }
        let mut p = 0;
        for (i, x) in d.nodes.iter().enumerate().skip(1) {
            if x[1] > d.nodes[p][1] {
                p = i;
            }
        }
        (1, p)
    }

    /// The C example's probe scene of `d`: no gravity, the nodes within
    /// 3 cm of the lowest (the box's bottom face) fixed instead of the
    /// scene's; the probe's start 2 mm above the pressed node and its
    /// deepest point `DEPTH` below it (the C example's float operations, in
    /// its order).
    fn scene(d: &Def, is_box: bool) -> (Def, usize, [f32; 3], [f32; 3]) {
        let (up, node) = pressed(d, is_box);
        let tray = if is_box { 0.0f32 } else { 0.03 };
        let lowest = d.nodes.iter().map(|x| x[up]).fold(d.nodes[0][up], f32::min);
        let fixed = (0..d.nodes.len() as u32)
            .filter(|&i| d.nodes[i as usize][up] <= lowest + tray)
            .collect();
        let settings = corofem_core::Settings {
            gravity: [0.0; 3],
            ..d.settings
        };
        let (mut c0, mut b) = (d.nodes[node], d.nodes[node]);
        c0[up] += RADIUS + 0.002;
        b[up] += RADIUS - DEPTH;
        let def = Def {
            nodes: d.nodes.clone(),
            tets: d.tets.clone(),
            fixed,
            settings,
            tip: Vec::new(),
            ..*d
        };
        (def, up, c0, b)
    }

    /// The C example's `probe_path`: the centre at the end of step `step`.
    use corofem_probe_path::path;

    /// What a run records: the hash, the final force on the probe, its
    /// largest push against the pressing direction, and the sum of its
    /// force along x (the slide's direction) over the first slide, steps
    /// 301 to 800 (N; times 1 ms, the impulse); with the coupling, every
    /// force rendered on the device.
    #[derive(Debug, PartialEq)]
    struct Run {
        hash: u64,
        force: [f32; 3],
        peak_push: f32,
        slide_x: f32,
        rendered: Vec<[f32; 3]>,
    }

    /// Adds step `k`'s force `f` to `run`.
    fn track(run: &mut Run, up: usize, k: u32, f: [f32; 3]) {
        run.peak_push = run.peak_push.max(f[up]);
        if (301..=800).contains(&k) {
            run.slide_x += f[0];
        }
        run.force = f;
    }

    fn empty() -> Run {
        Run {
            hash: 0,
            force: [0.0; 3],
            peak_push: 0.0,
            slide_x: 0.0,
            rendered: Vec::new(),
        }
    }

    /// The C example's coupling (`--coupling`): 1000 N/m, 2 N·s/m, 10 g.
    const COUPLING: (f32, f32, f32) = (1000.0, 2.0, 0.01);

    /// The device's velocity as the C example measures it: the difference
    /// of its positions over the period, in its float operations.
    fn velocity(at: [f32; 3], last: [f32; 3], dt: f32) -> [f32; 3] {
        [0, 1, 2].map(|c| (at[c] - last[c]) / dt)
    }

    /// Bit for bit: `-0.0` is not `0.0`, and NaN is itself.
    fn bits(forces: &[[f32; 3]]) -> Vec<[u32; 3]> {
        forces.iter().map(|f| f.map(f32::to_bits)).collect()
    }

    fn friction(on: bool) -> Option<(f32, f32)> {
        on.then_some((0.6, 0.4))
    }

    /// Through the Rust API.
    fn run_rust(d: &Def, is_box: bool, mu: Option<(f32, f32)>, coupled: bool, steps: u32) -> Run {
        let (d, up, c0, b) = scene(d, is_box);
        let mut s = corofem_core::VecScene::with_capacity(d.nodes.len(), d.tets.len());
        s.build(&d.nodes, &d.tets, &d.material, BuildOptions::default())
            .unwrap();
        s.set_settings(d.settings).unwrap();
        s.fix_nodes(&d.fixed).unwrap();
        let mut probes = [Probe::sphere(RADIUS, c0).unwrap()];
        if let Some((st, kin)) = mu {
            probes[0].set_friction(Friction::new(st, kin).unwrap());
        }
        let mut run = empty();
        let (k, damper, m) = COUPLING;
        let mut coupling = corofem_core::Coupling::new(k, damper, m).unwrap();
        let (dt, mut device) = (d.settings.dt, c0);
        for i in 0..steps {
            let at = path(c0, b, i + 1);
            if coupled {
                let v = velocity(at, device, dt);
                let f = coupling.drive(&mut probes[0], at, v, dt).unwrap();
                run.rendered.push(f);
                device = at;
            } else {
                probes[0].move_to(at, [0.0, 0.0, 1.0]).unwrap();
            }
            s.step_with_probes(&mut probes).unwrap();
            track(&mut run, up, i + 1, probes[0].force());
        }
        run.hash = s.state_hash();
        run
    }

    /// Through the C functions, the scene and the probes each in a heap
    /// buffer at an odd address.
    fn run_capi(d: &Def, is_box: bool, mu: Option<(f32, f32)>, coupled: bool, steps: u32) -> Run {
        let (d, up, c0, b) = scene(d, is_box);
        let d = &d;
        let (_buf, h) = capi_scene(d);
        // SAFETY (whole function): every pointer is a live local or a
        // slice of the stated length; the buffers outlive the handles.
        unsafe {
            let mut pbytes = 0usize;
            assert_eq!(
                corofem_capi::corofem_probes_bytes(1, &mut pbytes),
                Status::Ok
            );
            let mut pbuf = vec![0u8; pbytes + 1];
            let mut p: *mut ProbesHandle = std::ptr::null_mut();
            let st = corofem_capi::corofem_probes_init(
                pbuf.as_mut_ptr().add(1).cast(),
                pbytes,
                1,
                &mut p,
            );
            assert_eq!(st, Status::Ok);
            let mut index = usize::MAX;
            let st = corofem_capi::corofem_probes_add_sphere(p, RADIUS, c0.as_ptr(), &mut index);
            assert_eq!((st, index), (Status::Ok, 0));
            if let Some((st, kin)) = mu {
                assert_eq!(
                    corofem_capi::corofem_probe_set_friction(p, 0, st, kin),
                    Status::Ok
                );
            }
            let (mut force, mut contacts) = ([0.0f32; 3], 0u32);
            let mut stats = Stats::default();
            let mut run = empty();
            // The coupling: a plain struct of the caller's, here at an odd
            // 4-byte address inside a larger array.
            let mut words = [0u32; 22];
            let coupling = words.as_mut_ptr().add(1).cast::<corofem_capi::Coupling>();
            let (k, damper, m) = COUPLING;
            let st = corofem_capi::corofem_coupling_init(coupling, k, damper, m);
            assert_eq!(st, Status::Ok);
            let (dt, mut device) = (d.settings.dt, c0);
            for i in 0..steps {
                let at = path(c0, b, i + 1);
                let st = if coupled {
                    let v = velocity(at, device, dt);
                    let mut f = [f32::NAN; 3];
                    let st = corofem_capi::corofem_coupling_drive(
                        coupling,
                        p,
                        0,
                        at.as_ptr(),
                        v.as_ptr(),
                        dt,
                        f.as_mut_ptr(),
                    );
                    run.rendered.push(f);
                    device = at;
                    st
                } else {
                    corofem_capi::corofem_probe_move_to(p, 0, at.as_ptr(), std::ptr::null())
                };
                assert_eq!(st, Status::Ok, "step {i}");
                let st = corofem_capi::corofem_step_probes(
                    h,
                    p,
                    &mut stats,
                    std::ptr::null_mut(),
                    std::ptr::null_mut(),
                );
                assert_eq!(st, Status::Ok, "step {i}");
                let st = corofem_capi::corofem_probe_force(p, 0, force.as_mut_ptr(), &mut contacts);
                assert_eq!(st, Status::Ok);
                // The statistics count the probe's contacts (the scene
                // has no ground).
                assert_eq!(stats.contacts, contacts, "step {i}");
                track(&mut run, up, i + 1, force);
            }
            assert_eq!(stats.steps, u64::from(steps));
            let mut hash = 0u64;
            assert_eq!(corofem_capi::corofem_state_hash(h, &mut hash), Status::Ok);
            assert_eq!(corofem_capi::corofem_scene_deinit(h), Status::Ok);
            run.hash = hash;
            run
        }
    }

    /// The three ways agree, bit for bit; the probe pushed on the body
    /// while pressed; returns the Rust run.
    fn check(d: &Def, is_box: bool, with_friction: bool, coupled: bool, mesh_arg: &str) -> Run {
        let mu = friction(with_friction);
        let rust = run_rust(d, is_box, mu, coupled, STEPS);
        let capi = run_capi(d, is_box, mu, coupled, STEPS);
        println!(
            "{mesh_arg} probe{}{}: rust hash {:016x}, force {:?}, largest push {}",
            if with_friction { " with friction" } else { "" },
            if coupled { ", coupled" } else { "" },
            rust.hash,
            rust.force,
            rust.peak_push,
        );
        assert_eq!(rust.hash, capi.hash);
        assert_eq!(bits(&rust.rendered), bits(&capi.rendered));
        assert_eq!(rust, capi);
        assert_eq!(
            rust.rendered.len(),
            if coupled { STEPS as usize } else { 0 }
        );
        // Pressed 1 cm below the node's rest height, the body pushes the
        // probe back.
        assert!(rust.peak_push > 0.0, "{rust:?}");
        let mut args = vec![mesh_arg.to_owned(), STEPS.to_string(), "--probe".into()];
        if with_friction {
            args.push("--friction".into());
        }
        if coupled {
            args.push("--coupling".into());
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        if let Some(c) = run_c(&args) {
            assert_eq!(
                c, rust.hash,
                "C program hash {c:016x} vs Rust {:016x}",
                rust.hash
            );
        }
        rust
    }

    #[test]
    fn box_probe_same_hash_from_rust_and_c() {
        let plain = check(&box_def(), true, false, false, "box");
        let rough = check(&box_def(), true, true, false, "box");
        // Friction reached the solve: it changes the state, and over the
        // slide along +x the surface the probe drags holds it back (−x)
        // more than the frictionless surface it ploughs.
        assert_ne!(plain.hash, rough.hash);
        assert!(rough.slide_x < 0.0, "{rough:?}");
        assert!(rough.slide_x < plain.slide_x, "{rough:?} vs {plain:?}");
    }

    #[test]
    fn liver_probe_same_hash_from_rust_and_c() {
        // The finer liver: on SOFA's (edges of about 2 cm) a 1 cm sphere
        // slips between the surface nodes.
        let Some(path) = common::shared_mesh("liver_ftw_3k.tetmesh") else {
            return;
        };
        let p = path.to_string_lossy().into_owned();
        let d = liver_def(&path);
        let plain = check(&d, false, false, false, &p);
        let rough = check(&d, false, true, false, &p);
        // Friction reached the solve.
        assert_ne!(plain.hash, rough.hash);
    }

    /// `--coupling`: the path is the device's, the sphere its proxy; the
    /// coupling's forces and the state are the Rust `Coupling`'s, bit for
    /// bit.
    #[cfg(feature = "coupling")]
    #[test]
    fn coupled_probe_same_hash_from_rust_and_c() {
        let direct = check(&box_def(), true, false, false, "box");
        let coupled = check(&box_def(), true, false, true, "box");
        // The proxy is not the device: the body moved otherwise.
        assert_ne!(direct.hash, coupled.hash);
        // Pressed 1 cm in, the spring pulls the device back up (+z) at
        // the deepest point, step 300.
        let deepest = coupled.rendered[299];
        assert!(deepest[2] > 0.0, "{deepest:?}");
        let Some(path) = common::shared_mesh("liver_ftw_3k.tetmesh") else {
            return;
        };
        let p = path.to_string_lossy().into_owned();
        let d = liver_def(&path);
        let coupled = check(&d, false, false, true, &p);
        let deepest = coupled.rendered[299];
        assert!(deepest[1] > 0.0, "the liver's up is +y: {deepest:?}");
        check(&d, false, true, true, &p);
    }
}
