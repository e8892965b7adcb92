//! The core's math backends side by side. `run OUT` steps two scenes with the
//! backend this binary was built with and writes the final positions and the
//! time per step; `compare LIBM MICROMATH` reads two such files and prints
//! micromath's error against libm. `run.sh` does both builds and the comparison.
//!
//! The backend only supplies the square root (two per element and step, for
//! the QR frame's normalisations). `micromath`'s is a bit trick with a few
//! percent of relative error, so the frame's axes are not unit vectors and
//! the "rotation" is not one: the question is what that does to a body.

use corofem::{
    BoxMesh, BuildOptions, ElementBlock, Material, Node, NodeWork, Scene, Settings, SliceStorage,
};
use std::time::Instant;

/// The beam of `docs/bench.md`: 1 m × 0.2 m × 0.2 m, 20×4×4 cells of 6 tets.
const BEAM: BoxMesh = BoxMesh {
    size: [1.0, 0.2, 0.2],
    cells: [20, 4, 4],
    tets_per_cell: 6,
};
const STEPS: usize = 500;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    match args.get(1).map(String::as_str) {
        Some("run") if args.len() == 3 => run(&args[2]),
        Some("compare") if args.len() == 4 => compare(&args[2], &args[3]),
        _ => {
            eprintln!("usage: corofem-backend-compare run OUT | compare LIBM MICROMATH");
            std::process::exit(2);
        }
    }
}

/// One scene's result: final positions (m), elastic energy (J) and the
/// fastest time per step (s).
struct Outcome {
    positions: Vec<[f32; 3]>,
    elastic_energy: f32,
    seconds_per_step: f64,
}

/// Steps a beam `STEPS` times after `setup` and reports the final positions.
fn scene(setup: impl Fn(&mut Scene<SliceStorage<'_>>, &[[f32; 3]])) -> Outcome {
    let mut nodes = vec![[0.0f32; 3]; BEAM.node_count()];
    let mut tets = vec![[0u32; 4]; BEAM.tet_count()];
    BEAM.generate(&mut nodes, &mut tets).expect("the beam fits");
    let (mut n, mut w, mut e) = (
        vec![Node::EMPTY; nodes.len()],
        vec![NodeWork::EMPTY; nodes.len()],
        vec![ElementBlock::EMPTY; corofem::element_blocks(tets.len())],
    );
    let mut s = Scene::with_storage(SliceStorage::new(&mut n, &mut w, &mut e));
    let material = Material {
        young: 1.0e6,
        poisson: 0.3,
        density: 1000.0,
    };
    s.build(&nodes, &tets, &material, BuildOptions::default())
        .expect("the beam builds");
    setup(&mut s, &nodes);
    let mut best = f64::INFINITY;
    for _ in 0..STEPS {
        let t = Instant::now();
        s.step().expect("finite steps");
        best = best.min(t.elapsed().as_secs_f64());
    }
    Outcome {
        positions: s.positions().collect(),
        elastic_energy: s.elastic_energy(),
        seconds_per_step: best,
    }
}

/// The cantilever clamped at x = 0 sagging under gravity, and the same beam
/// free in space, spinning at 2 rad/s about its long axis' normal (a rigid
/// motion: any deformation it picks up is a ghost force).
fn run(out: &str) {
    let settings = Settings {
        dt: 1e-3,
        cg_iterations: 10,
        ..Settings::new().compiled()
    };
    let sag = scene(|s, x| {
        let clamp: Vec<u32> = (0..x.len() as u32)
            .filter(|&i| x[i as usize][0] <= 1e-6)
            .collect();
        s.fix_nodes(&clamp).unwrap();
        s.set_settings(settings).unwrap();
    });
    let spin = scene(|s, x| {
        s.set_settings(Settings {
            gravity: [0.0; 3],
            ..settings
        })
        .unwrap();
        // v = ω × (x − c), ω = (0, 0, 2) rad/s about the centre c.
        let v: Vec<[f32; 3]> = x
            .iter()
            .map(|p| [-2.0 * (p[1] - 0.1), 2.0 * (p[0] - 0.5), 0.0])
            .collect();
        s.set_velocities(&v).unwrap();
    });
    let mut text = String::new();
    for (name, o) in [("sag", &sag), ("spin", &spin)] {
        text += &format!(
            "{name} {} {:e} {:e}\n",
            o.positions.len(),
            o.seconds_per_step,
            o.elastic_energy
        );
        for p in &o.positions {
            text += &format!("{:e} {:e} {:e}\n", p[0], p[1], p[2]);
        }
    }
    std::fs::write(out, text).expect("writable output");
}

fn read(path: &str) -> Vec<(String, Outcome)> {
    let text = std::fs::read_to_string(path).expect("readable result");
    let mut lines = text.lines();
    let mut scenes = Vec::new();
    while let Some(head) = lines.next() {
        let f: Vec<&str> = head.split(' ').collect();
        let count: usize = f[1].parse().expect("a count");
        let positions = (0..count)
            .map(|_| {
                let v: Vec<f32> = lines
                    .next()
                    .expect("a line")
                    .split(' ')
                    .map(|x| x.parse().expect("a number"))
                    .collect();
                [v[0], v[1], v[2]]
            })
            .collect();
        scenes.push((
            f[0].to_string(),
            Outcome {
                positions,
                seconds_per_step: f[2].parse().expect("a time"),
                elastic_energy: f[3].parse().expect("an energy"),
            },
        ));
    }
    scenes
}

fn compare(libm: &str, micromath: &str) {
    let mut rest = vec![[0.0f32; 3]; BEAM.node_count()];
    let mut tets = vec![[0u32; 4]; BEAM.tet_count()];
    BEAM.generate(&mut rest, &mut tets).expect("the beam fits");
    println!(
        "scene  ms/step libm  micromath  ratio  position error  elastic energy (J) libm  micromath"
    );
    for ((name, a), (_, b)) in read(libm).iter().zip(read(micromath)) {
        let (mut diff, mut disp) = (0.0f64, 0.0f64);
        for ((p, q), x0) in a.positions.iter().zip(&b.positions).zip(&rest) {
            for c in 0..3 {
                diff += (f64::from(p[c]) - f64::from(q[c])).powi(2);
                disp += (f64::from(p[c]) - f64::from(x0[c])).powi(2);
            }
        }
        println!(
            "{name:5}  {:12.3}  {:9.3}  {:5.2}  {:14.2e}  {:23.3e}  {:9.3e}",
            a.seconds_per_step * 1e3,
            b.seconds_per_step * 1e3,
            b.seconds_per_step / a.seconds_per_step,
            (diff / disp).sqrt(),
            a.elastic_energy,
            b.elastic_energy,
        );
    }
    println!("position error: RMS of (micromath − libm) over RMS of libm's displacement from rest");
}
