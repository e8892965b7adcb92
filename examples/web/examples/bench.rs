//! Native time per step of the page's default scene (the clamped beam, 1920
//! tetrahedra, QR-invertible, two-level with 4 CG iterations from a warm
//! start, dt 2 ms), timed as the page times it:
//! 50 untimed steps, then 500 steps in one call; the best of 5 runs.
//!
//! Then the embedded surface's cost beside a step: the blob (2560
//! tetrahedra) and its smooth surface (3458 vertices, 6912 triangles),
//! `update_surface` + `vertex_normals` against a step, best of 5 runs.
//!
//! `cargo run --release --example bench` (add
//! `CARGO_PROFILE_RELEASE_OPT_LEVEL=3` for a speed-optimised build).

use std::time::Instant;

use corofem_web::demo::{App, Body, Params};

fn main() {
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let Ok(mut app) = App::body(Body::Beam, Params::DEFAULT) else {
            eprintln!("the beam does not build");
            std::process::exit(1);
        };
        app.step_frame(50);
        let t0 = Instant::now();
        let f = app.step_frame(500);
        let ms = t0.elapsed().as_secs_f64() * 1e3 / f64::from(f.steps.max(1));
        best = best.min(ms);
    }
    println!("native: {best:.3} ms/step (beam 1920 tets, QR-invertible, two-level, 4 CG iterations, warm, dt 2 ms)");

    let (mut step, mut surface) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        let Ok(mut app) = App::body(Body::Blob, Params::DEFAULT) else {
            eprintln!("the blob does not build");
            std::process::exit(1);
        };
        if app.embed(&Body::Blob.smooth_surface()).is_err() {
            eprintln!("the blob's surface does not bind");
            std::process::exit(1);
        }
        app.step_frame(50);
        let t0 = Instant::now();
        let f = app.step_frame(300);
        step = step.min(t0.elapsed().as_secs_f64() * 1e3 / f64::from(f.steps.max(1)));
        let t0 = Instant::now();
        for _ in 0..400 {
            if !matches!(app.update_embedded(), Ok(true)) {
                eprintln!("no surface to update");
                std::process::exit(1);
            }
        }
        surface = surface.min(t0.elapsed().as_secs_f64() * 1e3 / 400.0);
    }
    println!(
        "native: blob {step:.3} ms/step; its surface {:.1} µs per update_surface + vertex_normals ({:.3} steps)",
        surface * 1e3,
        surface / step
    );
}
