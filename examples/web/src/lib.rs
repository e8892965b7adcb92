//! corofem in the browser: a wasm32 module with plain `extern "C"` exports
//! (numbers in, numbers out; no bindings generator), driven by `www/app.js`.
//!
//! Memory: the body's size is known only at run time (a user's file), so the
//! scene's slots are `Vec`s (`corofem::VecScene`); the core itself stays
//! `no_std` and allocation-free. Data the page reads every frame (positions,
//! surface triangles, statistics) stay in this module's memory and are read
//! through typed-array views at the pointers the exports return.
//!
//! Strings (errors, notes) come back as UTF-8 bytes at `cf_message_ptr`, of
//! length `cf_message_len`. Files go the other way: `cf_input(len)` returns
//! a buffer the page fills before calling `cf_load_input` (a mesh) or
//! `cf_load_surface_input` (a surface to embed).
//!
//! The probe (`cf_probe_*`) is a rigid sphere pressed on the body: the page
//! finds where it first touches along the cursor's ray (`cf_probe_cast`),
//! sets where its centre is to be at the end of each frame (`cf_probe_set`)
//! and reads back its pose and the force the body exerts on it
//! (`cf_probe_state`).
//!
//! An embedded surface (`cf_embedded_*`) is drawn in place of the
//! tetrahedra's boundary: the built-in bodies come with one, a file may
//! replace it. It never changes the simulation; `cf_embedded_update` moves
//! it to the body's current shape, without allocating.
//!
//! All exports are safe functions; `#[no_mangle]` is the only attribute the
//! `unsafe_code` lint would name, so it is allowed here for that reason.

#![deny(unsafe_code)]

pub mod mesh_file;
pub mod surface_file;

pub use corofem_test_scenes::web as demo;

use std::cell::RefCell;

use corofem::Method;
use demo::{App, Body, Params, Support};
use mesh_file::Placement;

/// Everything the page talks to.
struct State {
    app: Option<App>,
    /// How the body's mesh was placed: a surface file goes the same way.
    placement: Placement,
    params: Params,
    /// The last error, or a note about the last load.
    message: String,
    /// A file's bytes, written by the page.
    input: Vec<u8>,
    /// Statistics of the last frame; see `cf_stats_ptr`.
    stats: [f32; STATS],
    /// Small vector results; see `cf_grab_state` and `cf_probe_state`.
    vec: [f32; 8],
}

/// Length of the statistics (f32 each); see `cf_stats_ptr`.
const STATS: usize = 16;

thread_local! {
    static STATE: RefCell<State> = const {
        RefCell::new(State {
            app: None,
            placement: Placement::IDENTITY,
            params: Params::DEFAULT,
            message: String::new(),
            input: Vec::new(),
            stats: [0.0; STATS],
            vec: [0.0; 8],
        })
    };
}

fn with<R>(f: impl FnOnce(&mut State) -> R) -> R {
    STATE.with(|s| f(&mut s.borrow_mut()))
}

fn with_app<R>(default: R, f: impl FnOnce(&mut App) -> R) -> R {
    with(|s| s.app.as_mut().map_or(default, f))
}

/// 0 for `Ok`; for an error, 1 with its text kept for `cf_message`.
fn outcome<E: core::fmt::Display>(s: &mut State, r: Result<(), E>) -> i32 {
    match r {
        Ok(()) => 0,
        Err(e) => {
            s.message = e.to_string();
            1
        }
    }
}

/// Pointer as the page sees it: an offset into the module's memory.
fn addr<T>(p: *const T) -> u32 {
    p as usize as u32
}

/// Method by page index: 0 Qr, 1 Polar, 2 Linear, 3 QrRestB, 4 QrInvertible.
fn method(i: u32) -> Option<Method> {
    [
        Method::Qr,
        Method::Polar,
        Method::Linear,
        Method::QrRestB,
        Method::QrInvertible,
    ]
    .get(i as usize)
    .copied()
}

fn install(s: &mut State, result: Result<(App, Placement), String>, note: String) -> i32 {
    match result {
        Ok((app, placement)) => {
            s.app = Some(app);
            s.placement = placement;
            s.stats = [0.0; STATS];
            s.message = note;
            0
        }
        Err(e) => {
            s.message = e;
            1
        }
    }
}

/// Loads built-in body `body` (0 cube, 1 beam, 2 blob) held by `support`
/// (0 ground, 1 clamp, 2 free, anything else: the body's default), with its
/// smooth surface embedded. Returns 0, or 1 with the error at
/// `cf_message_ptr` (the previous body stays).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_load_body(body: u32, support: u32) -> i32 {
    with(|s| {
        let Some(body) = Body::from_index(body) else {
            s.message = format!("no built-in body {body}");
            return 1;
        };
        let support = Support::from_index(support).unwrap_or(body.default_support());
        let r = App::new(&body.mesh(), support, s.params, false).and_then(|mut app| {
            app.embed(&body.smooth_surface())
                .map_err(|e| e.to_string())?;
            Ok((app, Placement::IDENTITY))
        });
        install(s, r, String::new())
    })
}

/// A buffer of `len` bytes for a file; returns its address.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_input(len: u32) -> u32 {
    with(|s| {
        s.input.clear();
        s.input.resize(len as usize, 0);
        addr(s.input.as_ptr())
    })
}

/// Reads the `tetmesh 1` or Gmsh `.msh` file in the input buffer and loads
/// it held by `support` (as `cf_load_body`; default ground), with no
/// embedded surface. Negatively oriented tetrahedra are re-oriented.
/// Returns 0 (a note, if any, at `cf_message_ptr`) or 1 with the error
/// there (the previous body stays).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_load_input(support: u32) -> i32 {
    with(|s| {
        let support = Support::from_index(support).unwrap_or(Support::Ground);
        let input = std::mem::take(&mut s.input);
        let r = mesh_file::parse(&input).and_then(|m| mesh_file::prepare(&m));
        match r {
            Ok((mesh, placement, note)) => {
                let r = App::new(&mesh, support, s.params, true).map(|app| (app, placement));
                install(s, r, note)
            }
            Err(e) => {
                s.message = e;
                1
            }
        }
    })
}

/// Reads the OBJ or STL file in the input buffer, laid out as its name
/// (`name_len` bytes of UTF-8; the extension tells the format) followed by
/// its bytes, and embeds it in the body, placed as the body's mesh was (a
/// file's mesh may have been scaled), in place of the surface embedded
/// before. Returns 0 with a note at `cf_message_ptr` (its counts, and how
/// far outside the tetrahedra its vertices reach), or 1 with the error
/// there (the body and its surface stay).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_load_surface_input(name_len: u32) -> i32 {
    with(|s| {
        let input = std::mem::take(&mut s.input);
        let (name, bytes) = input.split_at(input.len().min(name_len as usize));
        let name = String::from_utf8_lossy(name);
        let placement = s.placement;
        let Some(app) = s.app.as_mut() else {
            s.message = "no body to embed the surface in".to_owned();
            return 1;
        };
        let surface = match surface_file::parse(bytes, &name, &placement) {
            Ok(surface) => surface,
            Err(e) => {
                s.message = e;
                return 1;
            }
        };
        let reach = app.embed_reach();
        match app.embed(&surface) {
            Ok(e) => {
                let st = e.stats();
                let mut note = format!(
                    "{} vertices, {} triangles",
                    surface.vertices.len(),
                    surface.triangles.len()
                );
                if st.outside > 0 && st.max_distance > 0.0 {
                    note.push_str(&format!(
                        "; {} outside the tetrahedra, by at most {} mm",
                        st.outside,
                        mesh_file::sig3(1e3 * f64::from(st.max_distance))
                    ));
                }
                s.message = note;
                0
            }
            Err(e) => {
                s.message = surface_file::bind_error(&e, reach, placement.scale());
                1
            }
        }
    })
}

/// Number of vertices of the embedded surface (0 when there is none).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_embedded_vertex_count() -> u32 {
    with_app(0, |a| {
        a.embedded().map_or(0, |e| e.positions().len() as u32)
    })
}

/// Number of triangles of the embedded surface.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_embedded_triangle_count() -> u32 {
    with_app(0, |a| {
        a.embedded().map_or(0, |e| e.triangles().len() as u32)
    })
}

/// Address of the embedded surface's triangles (3 × u32 each, wound
/// counter-clockwise seen from outside).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_embedded_triangles_ptr() -> u32 {
    with_app(0, |a| {
        a.embedded().map_or(0, |e| addr(e.triangles().as_ptr()))
    })
}

/// Address of the embedded surface's current positions (3 × f32 per
/// vertex, m), refreshed by `cf_embedded_update`.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_embedded_positions_ptr() -> u32 {
    with_app(0, |a| {
        a.embedded().map_or(0, |e| addr(e.positions().as_ptr()))
    })
}

/// Address of the embedded surface's unit vertex normals (3 × f32 per
/// vertex), refreshed with the positions.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_embedded_normals_ptr() -> u32 {
    with_app(0, |a| {
        a.embedded().map_or(0, |e| addr(e.normals().as_ptr()))
    })
}

/// Address of one byte per vertex of the embedded surface: 1 when every
/// node it follows is fixed (drawn like the clamped nodes), else 0.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_embedded_held_ptr() -> u32 {
    with_app(0, |a| a.embedded().map_or(0, |e| addr(e.held().as_ptr())))
}

/// Moves the embedded surface to the body's current shape (positions, then
/// vertex normals), allocating nothing. Returns 1, or 0 when there is none.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_embedded_update() -> u32 {
    with_app(0, |a| u32::from(a.update_embedded().unwrap_or(false)))
}

/// Address of the last message (UTF-8).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_message_ptr() -> u32 {
    with(|s| addr(s.message.as_ptr()))
}

/// Length of the last message in bytes.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_message_len() -> u32 {
    with(|s| s.message.len() as u32)
}

/// Sets the controls: Young's modulus (Pa), Poisson ratio, method (0 Qr,
/// 1 Polar, 2 Linear, 3 QrRestB, 4 QrInvertible), time step (s), CG iterations, gravity
/// (0 off), preconditioner (0 mass, 1 block-Jacobi, 2 two-level). Kept for
/// the next body too. Returns 0, or 1 with the error.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_set_params(
    young: f32,
    poisson: f32,
    method_index: u32,
    dt: f32,
    cg_iterations: u32,
    gravity: u32,
    preconditioner_index: u32,
) -> i32 {
    with(|s| {
        let Some(m) = method(method_index) else {
            s.message = format!("no method {method_index}");
            return 1;
        };
        let Some(&pre) = corofem::Preconditioner::VARIANTS.get(preconditioner_index as usize)
        else {
            s.message = format!("no preconditioner {preconditioner_index}");
            return 1;
        };
        let p = Params {
            young,
            poisson,
            method: m,
            dt,
            cg_iterations,
            gravity: gravity != 0,
            preconditioner: pre,
            ..s.params
        };
        let r = match s.app.as_mut() {
            Some(app) => app.set_params(p),
            None => Ok(()),
        };
        match r {
            Ok(()) => {
                s.params = p;
                0
            }
            Err(e) => {
                s.message = e;
                1
            }
        }
    })
}

/// Number of nodes of the body.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_node_count() -> u32 {
    with_app(0, |a| a.scene().node_count() as u32)
}

/// Number of tetrahedra of the body.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_tet_count() -> u32 {
    with_app(0, |a| a.scene().element_count() as u32)
}

/// Address of the surface triangles (3 × u32 each, outward winding).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_surface_ptr() -> u32 {
    with_app(0, |a| addr(a.surface().as_ptr()))
}

/// Number of surface triangles.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_surface_count() -> u32 {
    with_app(0, |a| a.surface().len() as u32)
}

/// Address of the current positions (3 × f32 per node, m).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_positions_ptr() -> u32 {
    with_app(0, |a| addr(a.positions().as_ptr()))
}

/// Address of the fixed node indices (u32).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_fixed_ptr() -> u32 {
    with_app(0, |a| addr(a.fixed().as_ptr()))
}

/// Number of fixed nodes.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_fixed_count() -> u32 {
    with_app(0, |a| a.fixed().len() as u32)
}

/// How the body is held: 0 ground, 1 clamp, 2 free.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_support() -> u32 {
    with_app(0, |a| match a.support() {
        Support::Ground => 0,
        Support::Clamp => 1,
        Support::Free => 2,
    })
}

/// Mean edge length of the body (m).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_mean_edge() -> f32 {
    with_app(0.0, |a| a.mean_edge())
}

/// Runs up to `substeps` steps and refreshes the positions and the
/// statistics. Returns the steps taken (fewer if a step was refused).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_step(substeps: u32) -> u32 {
    with(|s| {
        let Some(app) = s.app.as_mut() else {
            return 0;
        };
        let f = app.step_frame(substeps);
        let l = spin(app);
        s.stats = [
            f.steps as f32,
            f.inverted as f32,
            f.contacts as f32,
            f.tool_force[0],
            f.tool_force[1],
            f.tool_force[2],
            f.cg_residual,
            if f.diverged { 1.0 } else { 0.0 },
            app.scene().time() as f32,
            (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt(),
            app.scene().kinetic_energy(),
            f.probe_contacts as f32,
            f.probe_force[0],
            f.probe_force[1],
            f.probe_force[2],
            if f.probe_moved_out { 1.0 } else { 0.0 },
        ];
        f.steps
    })
}

/// Angular momentum about the centre of mass, `L − c × p` (kg·m²/s): what
/// stays constant for a free body unless something (a ghost torque) turns it.
fn spin(app: &App) -> [f32; 3] {
    let s = app.scene();
    let (mut m, mut c) = (0.0f32, [0.0f32; 3]);
    for i in 0..s.node_count() as u32 {
        if let (Some(mi), Some(x)) = (s.mass(i), s.position(i)) {
            m += mi;
            c = [c[0] + mi * x[0], c[1] + mi * x[1], c[2] + mi * x[2]];
        }
    }
    let c = [c[0] / m, c[1] / m, c[2] / m];
    let (l, p) = (s.angular_momentum(), s.momentum());
    [
        l[0] - (c[1] * p[2] - c[2] * p[1]),
        l[1] - (c[2] * p[0] - c[0] * p[2]),
        l[2] - (c[0] * p[1] - c[1] * p[0]),
    ]
}

/// Address of the last frame's statistics, 16 × f32: steps, inverted
/// elements, contacts (ground and probe), tool force x y z (N), CG
/// residual, diverged (0/1), simulated time (s), |angular momentum about
/// the centre of mass| (kg·m²/s), kinetic energy (J), probe contacts, force
/// of the body on the probe x y z (N), probe moved out (0/1: it would have
/// started inside the body).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_stats_ptr() -> u32 {
    with(|s| addr(s.stats.as_ptr()))
}

/// Nearest surface hit of the ray `o + t d`: returns `t`, or −1 for a miss.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_pick(ox: f32, oy: f32, oz: f32, dx: f32, dy: f32, dz: f32) -> f32 {
    with_app(-1.0, |a| {
        a.pick([ox, oy, oz], [dx, dy, dz]).map_or(-1.0, |h| h.t)
    })
}

/// Grabs the body around the surface point `(x, y, z)` (m) with the tool.
/// Returns the number of nodes grabbed.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_grab(x: f32, y: f32, z: f32) -> u32 {
    with_app(0, |a| a.grab([x, y, z]) as u32)
}

/// Moves the tool: the grabbed point is pulled to `(x, y, z)` (m).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_set_target(x: f32, y: f32, z: f32) {
    with_app((), |a| a.set_target([x, y, z]));
}

/// Lets go.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_release() {
    with_app((), App::release);
}

/// When grabbing, writes where the spring attaches to the body and where it
/// pulls to (2 × xyz, m) at `cf_vec_ptr` and returns 1; otherwise 0.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_grab_state() -> u32 {
    with(|s| {
        let Some(app) = s.app.as_ref() else {
            return 0;
        };
        match (app.grab_point(), app.target()) {
            (Some(p), Some(t)) => {
                s.vec = [p[0], p[1], p[2], t[0], t[1], t[2], 0.0, 0.0];
                1
            }
            _ => 0,
        }
    })
}

/// Address of the small vector results (8 × f32).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_vec_ptr() -> u32 {
    with(|s| addr(s.vec.as_ptr()))
}

/// Address of the grabbed node indices (u32).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_grabbed_ptr() -> u32 {
    with_app(0, |a| addr(a.grabbed().as_ptr()))
}

/// Number of grabbed nodes.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_grabbed_count() -> u32 {
    with_app(0, |a| a.grabbed().len() as u32)
}

/// Where a sphere of radius `r` (m) moving along the ray `o + t d` first
/// touches the body's boundary nodes (the only nodes a probe touches),
/// stopping a hair short: returns its centre's `t`, or −1 when it misses
/// the body, starts around a node already, or for input that is not finite.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_probe_cast(
    ox: f32,
    oy: f32,
    oz: f32,
    dx: f32,
    dy: f32,
    dz: f32,
    r: f32,
) -> f32 {
    with_app(-1.0, |a| {
        a.probe_cast([ox, oy, oz], [dx, dy, dz], r).unwrap_or(-1.0)
    })
}

/// Presses the probe, a sphere of radius `r` (m), on the body: its centre is
/// to reach `(x, y, z)` (m) by the end of the next frame, pressing along
/// `(dx, dy, dz)` (any length > 0). Without a probe, or with one of another
/// radius, a new one is made at `(x, y, z)`; if its first step would start
/// with a node inside it, it is moved out against the press direction
/// first (the frame's statistics say so). Returns 0, or 1 with the error
/// at `cf_message_ptr` and nothing changed (no body, a radius that is not
/// finite and > 0, a point or direction that is not finite, a zero
/// direction).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_probe_set(x: f32, y: f32, z: f32, r: f32, dx: f32, dy: f32, dz: f32) -> i32 {
    with(|s| {
        let Some(app) = s.app.as_mut() else {
            s.message = "no body to press on".to_owned();
            return 1;
        };
        let r = app.set_probe([x, y, z], r, [dx, dy, dz]);
        outcome(s, r)
    })
}

/// Sets the Coulomb friction coefficient (static and kinetic) between the
/// probe and the body, kept for later probes too. Returns 0, or 1 with the
/// error (not finite or < 0) and nothing changed.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_probe_friction(mu: f32) -> i32 {
    with(|s| {
        let r = s
            .app
            .as_mut()
            .map_or(Ok(()), |app| app.set_probe_friction(mu));
        outcome(s, r)
    })
}

/// Sets the Coulomb friction coefficient (static and kinetic) between the
/// body and the ground (none by default). Returns 0, or 1 with the error
/// (not finite or < 0) and nothing changed.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_ground_friction(mu: f32) -> i32 {
    with(|s| {
        let r = s
            .app
            .as_mut()
            .map_or(Ok(()), |app| app.set_ground_friction(mu));
        outcome(s, r)
    })
}

/// Takes the probe away.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_probe_clear() {
    with_app((), demo::App::clear_probe);
}

/// When a probe is on the body, writes its centre (where the last step
/// left it, m), its radius (m), the force the body exerted on it in the
/// last step (N) and the nodes it held (8 × f32) at `cf_vec_ptr` and
/// returns 1; otherwise 0.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_probe_state() -> u32 {
    with(|s| {
        let Some(p) = s.app.as_ref().and_then(App::probe) else {
            return 0;
        };
        let (c, f) = (p.position(), p.force());
        s.vec = [
            c[0],
            c[1],
            c[2],
            p.radius(),
            f[0],
            f[1],
            f[2],
            p.contacts() as f32,
        ];
        1
    })
}

/// Back to the rest shape, at rest, tool released, probe taken away.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_reset() {
    with(|s| {
        if let Some(app) = s.app.as_mut() {
            app.reset();
        }
        s.stats = [0.0; STATS];
    });
}

/// The core's state hash (bits of every displacement and velocity).
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_state_hash() -> u64 {
    with_app(0, |a| a.scene().state_hash())
}

/// Runs [`demo::hash_script`] and returns its hash (0 if it failed, with
/// the error at `cf_message_ptr`). Leaves the page's body alone.
#[allow(unsafe_code)]
#[no_mangle]
pub extern "C" fn cf_hash_script() -> u64 {
    match demo::hash_script() {
        Ok(h) => h,
        Err(e) => {
            with(|s| s.message = e);
            0
        }
    }
}
