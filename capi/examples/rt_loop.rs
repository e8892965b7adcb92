//! A 1 kHz haptic loop with its worst case measured.
//!
//! ```text
//! cargo run --release --example rt_loop -- [--scene liver|liver-ftw|box10k|FILE.tetmesh]
//!     [--probe [--friction]] [--steps 100000] [--rate 1000] [--cg 10] [--preconditioner NAME]
//!     [--load] [--cpu N] [--fifo PRIO]
//!     [--spin-us 50] [--no-slack] [--no-mlock] [--no-prefault] [--ftz] [--still] [--json]
//! ```
//!
//! Each period: sleep to `deadline − spin` with `clock_nanosleep(TIMER_ABSTIME)`,
//! spin to the deadline, move the tool target, step, record. Two numbers per
//! step go into buffers allocated and touched before the loop: the *step
//! time* (what the solver costs) and the *wake-up latency* (how late the OS
//! woke us: what the machine costs). A deadline is missed when a step ends
//! after the next deadline; the loop then skips the periods it lost.
//!
//! `--scene liver` is SOFA's liver, `liver-ftw` the finer fTetWild liver
//! (`liver_ftw_3k.tetmesh`), both from `../shared/meshes`; a file is read
//! as one in SOFA's liver units. `--probe` replaces the tool with the probe
//! scene of `haptic_loop.c --probe` (feature `probe`): a 1 cm sphere
//! pressing 1 cm into the liver from above over 0.3 s, sliding 15 mm in
//! 0.5 s, lifting in 0.3 s and returning in 0.1 s, the bottom 3 cm of the
//! liver fixed, no gravity; `--friction` gives it Coulomb friction (static
//! 0.6, kinetic 0.4; feature `friction`). Use it on `liver-ftw`: on SOFA's
//! liver, whose edges are about 2 cm, the sphere slips between the nodes.
//!
//! `--cg N` sets the CG iterations (default 10 for the liver, 5 for the
//! box); `--preconditioner NAME` (`mass`, `block-jacobi`, `two-level`)
//! replaces the scenes' lumped mass (the paper's CG, from zero), with warm
//! start for the other two.
//!
//! `--load` runs a busy thread on every other core (or unpinned) for the
//! whole loop. `--cpu N` pins the loop thread (and keeps the load off that
//! core); `--fifo PRIO` asks for `SCHED_FIFO` (needs root or
//! `CAP_SYS_NICE`; refused quietly otherwise and reported). Memory is
//! locked with `mlockall` unless `--no-mlock`, and the stack, the scene and
//! the buffers are touched before the loop unless `--no-prefault`.
//! The timer slack is set to 1 ns unless `--no-slack`.
//! `--ftz` sets flush-to-zero and denormals-are-zero (x86_64), to test
//! whether denormals cost anything; it changes results if any occur.
//! `--still` holds the tool still so the body comes to rest (where velocities
//! decay towards denormal range).
//!
//! docs/capi.md's step-time figures come from this program.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use corofem_core::VecScene;
use corofem_core::{
    BoxMesh, BuildOptions, Material, Preconditioner, Settings, StepError, StepStats,
};

struct Args {
    scene: String,
    probe: bool,
    friction: bool,
    steps: usize,
    rate: f64,
    cg: Option<u32>,
    preconditioner: Option<Preconditioner>,
    load: bool,
    cpu: Option<usize>,
    fifo: Option<i32>,
    spin_us: u64,
    mlock: bool,
    prefault: bool,
    ftz: bool,
    slack: bool,
    still: bool,
    json: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        scene: "liver".into(),
        probe: false,
        friction: false,
        steps: 100_000,
        rate: 1000.0,
        cg: None,
        preconditioner: None,
        load: false,
        cpu: None,
        fifo: None,
        spin_us: 50,
        mlock: true,
        prefault: true,
        ftz: false,
        slack: true,
        still: false,
        json: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut val = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match arg.as_str() {
            "--scene" => a.scene = val("--scene")?,
            "--steps" => {
                a.steps = val("--steps")?
                    .parse()
                    .map_err(|e| format!("--steps: {e}"))?
            }
            "--rate" => a.rate = val("--rate")?.parse().map_err(|e| format!("--rate: {e}"))?,
            "--cg" => a.cg = Some(val("--cg")?.parse().map_err(|e| format!("--cg: {e}"))?),
            "--preconditioner" => {
                let name = val("--preconditioner")?;
                a.preconditioner = Some(
                    Preconditioner::from_name(&name)
                        .ok_or_else(|| format!("--preconditioner: no preconditioner {name:?}"))?,
                );
            }
            "--cpu" => a.cpu = Some(val("--cpu")?.parse().map_err(|e| format!("--cpu: {e}"))?),
            "--fifo" => a.fifo = Some(val("--fifo")?.parse().map_err(|e| format!("--fifo: {e}"))?),
            "--spin-us" => {
                a.spin_us = val("--spin-us")?
                    .parse()
                    .map_err(|e| format!("--spin-us: {e}"))?
            }
            "--probe" => a.probe = true,
            "--friction" => a.friction = true,
            "--load" => a.load = true,
            "--no-mlock" => a.mlock = false,
            "--no-prefault" => a.prefault = false,
            "--ftz" => a.ftz = true,
            "--no-slack" => a.slack = false,
            "--still" => a.still = true,
            "--json" => a.json = true,
            "-h" | "--help" => {
                println!(
                    "{}",
                    include_str!("rt_loop.rs")
                        .lines()
                        .take(9)
                        .collect::<Vec<_>>()
                        .join("\n")
                );
                std::process::exit(0);
            }
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if a.steps == 0 || a.rate.is_nan() || a.rate <= 0.0 {
        return Err("--steps and --rate must be positive".into());
    }
    if a.friction && !a.probe {
        return Err("--friction needs --probe".into());
    }
    Ok(a)
}

/// A haptic scene: the built scene and how the tool moves.
struct Haptic {
    name: String,
    scene: VecScene,
    start: [f32; 3],
    /// Radius (m) of the tool's circle, in the plane of `axes`.
    radius: f32,
    axes: [usize; 2],
    /// With `--probe`: the probe that replaces the tool.
    press: Option<Press>,
}

/// The probe scene of `haptic_loop.c --probe`: a sphere of 1 cm, pressed
/// 1 cm below a node from 2 mm above it, slid and lifted.
#[cfg(feature = "probe")]
struct Press {
    probes: [corofem_core::Probe; 1],
    /// The sphere's centre at the start and at its deepest.
    start: [f32; 3],
    deepest: [f32; 3],
}

/// Without the feature `probe` there is no probe scene.
#[cfg(not(feature = "probe"))]
enum Press {}

#[cfg(feature = "probe")]
impl Press {
    const RADIUS: f32 = 0.01;
    const DEPTH: f32 = 0.01;

    /// Turns the liver scene `s` of `nodes` into the probe scene: no
    /// gravity, no tool, the nodes within 3 cm of the lowest (along +y,
    /// up) fixed, the sphere over the first node of the largest height.
    fn on(s: &mut VecScene, nodes: &[[f32; 3]], friction: bool) -> Result<(Self, usize), String> {
        const UP: usize = 1;
        let e = |e: corofem_core::Error| e.to_string();
        s.release();
        s.unfix_all();
        let lowest = nodes.iter().map(|x| x[UP]).fold(nodes[0][UP], f32::min);
        let tray: Vec<u32> = (0..nodes.len() as u32)
            .filter(|&i| nodes[i as usize][UP] <= lowest + 0.03)
            .collect();
        s.fix_nodes(&tray).map_err(e)?;
        s.set_settings(Settings {
            gravity: [0.0; 3],
            ..*s.settings()
        })
        .map_err(e)?;
        let mut top = 0;
        for (i, x) in nodes.iter().enumerate().skip(1) {
            if x[UP] > nodes[top][UP] {
                top = i;
            }
        }
        let (mut start, mut deepest) = (nodes[top], nodes[top]);
        start[UP] += Self::RADIUS + 0.002;
        deepest[UP] += Self::RADIUS - Self::DEPTH;
        let probe = corofem_core::Probe::sphere(Self::RADIUS, start).map_err(e)?;
        let press = Self {
            probes: [Self::rough(probe, friction)?],
            start,
            deepest,
        };
        Ok((press, tray.len()))
    }

    /// `probe` with Coulomb friction (static 0.6, kinetic 0.4) if asked.
    #[cfg(feature = "friction")]
    fn rough(
        mut probe: corofem_core::Probe,
        friction: bool,
    ) -> Result<corofem_core::Probe, String> {
        if friction {
            let mu = corofem_core::Friction::new(0.6, 0.4).map_err(|e| e.to_string())?;
            probe.set_friction(mu);
        }
        Ok(probe)
    }

    #[cfg(not(feature = "friction"))]
    fn rough(probe: corofem_core::Probe, friction: bool) -> Result<corofem_core::Probe, String> {
        if friction {
            return Err("--friction: built without the feature friction".into());
        }
        Ok(probe)
    }

    /// The sphere's centre at the end of step `step` (1-based), as
    /// `haptic_loop.c`'s `probe_path`.
    fn path(&self, step: u32) -> [f32; 3] {
        corofem_probe_path::path(self.start, self.deepest, step)
    }

    /// One period: the sphere moved along the path, a step, and the force
    /// the body exerted on it (what the device renders).
    fn step(&mut self, s: &mut VecScene, step: u32) -> Result<(StepStats, [f32; 3]), StepError> {
        // The pose is finite and the axis the sphere's own: never refused.
        let _ = self.probes[0].move_to(self.path(step), [0.0, 0.0, 1.0]);
        let st = s.step_with_probes(&mut self.probes)?;
        Ok((st, self.probes[0].force()))
    }
}

#[cfg(not(feature = "probe"))]
impl Press {
    fn on(_: &mut VecScene, _: &[[f32; 3]], _: bool) -> Result<(Self, usize), String> {
        Err("--probe: built without the feature probe".into())
    }

    fn step(&mut self, _: &mut VecScene, _: u32) -> Result<(StepStats, [f32; 3]), StepError> {
        match *self {}
    }
}

fn liver(path: &str, cg: u32, probe: Option<bool>) -> Result<Haptic, String> {
    let mesh = corofem_io::read_mesh(std::path::Path::new(path)).map_err(|e| e.to_string())?;
    let (nodes, tets) = corofem_io::to_core(&mesh, 0.03);
    let mut s = corofem_core::VecScene::with_capacity(nodes.len(), tets.len());
    let material = Material {
        young: 5.0e3,
        poisson: 0.45,
        density: 1000.0,
    };
    s.build(&nodes, &tets, &material, BuildOptions::default())
        .map_err(|e| e.to_string())?;
    s.set_settings(Settings {
        dt: 0.001,
        cg_iterations: cg,
        rayleigh_mass: 1.0,
        rayleigh_stiffness: 0.01,
        gravity: [0.0, -9.81, 0.0],
        // The paper's CG unless `--preconditioner` says otherwise.
        ..Settings::with_preconditioner(Preconditioner::Mass)
    })
    .map_err(|e| e.to_string())?;
    s.fix_nodes(&[3, 39, 64]).map_err(|e| e.to_string())?;
    s.grab(&[80, 81, 78, 83, 82], 2000.0)
        .map_err(|e| e.to_string())?;
    let mut name = format!("liver ({} nodes, {} tets)", nodes.len(), tets.len());
    // `--probe [--friction]`: the probe scene instead of the tool.
    let press = match probe {
        Some(friction) => {
            let (press, tray) = Press::on(&mut s, &nodes, friction)?;
            name += &format!(
                ", a 1 cm probe{} pressed 1 cm, {tray} nodes on the tray",
                if friction { " with friction" } else { "" }
            );
            Some(press)
        }
        None => None,
    };
    Ok(Haptic {
        name,
        start: s.tool_target(),
        scene: s,
        radius: 0.02,
        axes: [0, 1],
        press,
    })
}

/// A 10 cm cube of 12³ cells × 6 = 10 368 tetrahedra (2197 nodes), fixed at
/// its base, grabbed at the middle of its top face.
fn box10k(cg: u32) -> Result<Haptic, String> {
    let n = 12u32;
    let mesh = BoxMesh {
        size: [0.1; 3],
        cells: [n; 3],
        tets_per_cell: 6,
    };
    let mut nodes = vec![[0.0; 3]; mesh.node_count()];
    let mut tets = vec![[0; 4]; mesh.tet_count()];
    mesh.generate(&mut nodes, &mut tets)
        .map_err(|e| e.to_string())?;
    let mut s = corofem_core::VecScene::with_capacity(nodes.len(), tets.len());
    let material = Material {
        young: 1.0e4,
        poisson: 0.45,
        density: 1000.0,
    };
    s.build(&nodes, &tets, &material, BuildOptions::default())
        .map_err(|e| e.to_string())?;
    s.set_settings(Settings {
        dt: 0.001,
        cg_iterations: cg,
        rayleigh_mass: 1.0,
        rayleigh_stiffness: 0.01,
        // The paper's CG unless `--preconditioner` says otherwise.
        ..Settings::with_preconditioner(Preconditioner::Mass)
    })
    .map_err(|e| e.to_string())?;
    let idx = |i: u32, j: u32, k: u32| i + (n + 1) * (j + (n + 1) * k);
    let base: Vec<u32> = (0..=n)
        .flat_map(|j| (0..=n).map(move |i| idx(i, j, 0)))
        .collect();
    s.fix_nodes(&base).map_err(|e| e.to_string())?;
    let top: Vec<u32> = (5..=7)
        .flat_map(|j| (5..=7).map(move |i| idx(i, j, n)))
        .collect();
    s.grab(&top, 500.0).map_err(|e| e.to_string())?;
    Ok(Haptic {
        name: format!("box ({} nodes, {} tets)", nodes.len(), tets.len()),
        start: s.tool_target(),
        scene: s,
        radius: 0.01,
        axes: [0, 2],
        press: None,
    })
}

fn now_ns() -> i64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: a valid out-pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec * 1_000_000_000 + ts.tv_nsec
}

fn sleep_until(t_ns: i64) {
    let ts = libc::timespec {
        tv_sec: t_ns / 1_000_000_000,
        tv_nsec: t_ns % 1_000_000_000,
    };
    // SAFETY: valid pointers; EINTR just wakes us early, the spin follows.
    unsafe {
        libc::clock_nanosleep(
            libc::CLOCK_MONOTONIC,
            libc::TIMER_ABSTIME,
            &ts,
            std::ptr::null_mut(),
        )
    };
}

fn pin(cpu: usize) -> bool {
    // SAFETY: a zeroed cpu_set_t is valid; the calls only read it.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set) == 0
    }
}

fn set_fifo(prio: i32) -> bool {
    let p = libc::sched_param {
        sched_priority: prio,
    };
    // SAFETY: a valid parameter struct.
    unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &p) == 0 }
}

#[derive(Default, Clone, Copy)]
struct Usage {
    minflt: i64,
    majflt: i64,
    nvcsw: i64,
    nivcsw: i64,
}

fn usage() -> Usage {
    // SAFETY: a zeroed rusage is valid; getrusage fills it.
    unsafe {
        let mut r: libc::rusage = std::mem::zeroed();
        libc::getrusage(libc::RUSAGE_THREAD, &mut r);
        Usage {
            minflt: r.ru_minflt,
            majflt: r.ru_majflt,
            nvcsw: r.ru_nvcsw,
            nivcsw: r.ru_nivcsw,
        }
    }
}

/// Flush-to-zero and denormals-are-zero on x86_64 (MXCSR bits 15 and 6).
#[cfg(target_arch = "x86_64")]
fn set_ftz() -> bool {
    let mut csr: u32 = 0;
    // SAFETY: reads and writes this thread's MXCSR only.
    unsafe {
        std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr, options(nostack));
        csr |= (1 << 15) | (1 << 6);
        std::arch::asm!("ldmxcsr [{}]", in(reg) &csr, options(nostack));
    }
    true
}

#[cfg(not(target_arch = "x86_64"))]
fn set_ftz() -> bool {
    false
}

/// Touches `bytes` of stack so the loop never faults a new stack page in.
#[inline(never)]
fn prefault_stack(bytes: usize) {
    let mut buf = [0u8; 256 * 1024];
    let n = bytes.min(buf.len());
    for i in (0..n).step_by(4096) {
        // SAFETY: in bounds; volatile so the writes are not optimised away.
        unsafe { std::ptr::write_volatile(buf.as_mut_ptr().add(i), 1) };
    }
    std::hint::black_box(&buf);
}

/// Percentile of sorted values (nearest rank).
fn pct(sorted: &[i64], p: f64) -> i64 {
    if sorted.is_empty() {
        return 0;
    }
    let k = ((p / 100.0) * sorted.len() as f64).ceil() as usize;
    sorted[k.clamp(1, sorted.len()) - 1]
}

struct Summary {
    median: i64,
    p99: i64,
    p999: i64,
    max: i64,
}

fn summary(v: &mut [i64]) -> Summary {
    v.sort_unstable();
    Summary {
        median: pct(v, 50.0),
        p99: pct(v, 99.0),
        p999: pct(v, 99.9),
        max: v.last().copied().unwrap_or(0),
    }
}

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("rt_loop: {e}");
            std::process::exit(2);
        }
    };
    let shared = |name: &str| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/meshes")
            .join(name)
            .to_string_lossy()
            .into_owned()
    };
    let probe = args.probe.then_some(args.friction);
    let built = match args.scene.as_str() {
        "liver" => liver(&shared("sofa_liver.tetmesh"), args.cg.unwrap_or(10), probe),
        "liver-ftw" => liver(
            &shared("liver_ftw_3k.tetmesh"),
            args.cg.unwrap_or(10),
            probe,
        ),
        "box10k" if args.probe => Err("--probe: on a liver (liver, liver-ftw or a file)".into()),
        "box10k" => box10k(args.cg.unwrap_or(5)),
        path => liver(path, args.cg.unwrap_or(10), probe),
    };
    let mut h = match built {
        Ok(h) => h,
        Err(e) => {
            eprintln!("rt_loop: {e}");
            std::process::exit(2);
        }
    };
    if let Some(pre) = args.preconditioner {
        // Another preconditioner than the scene's: with warm start unless
        // it is the lumped mass (the paper's CG, from zero).
        let settings = Settings {
            preconditioner: pre,
            warm_start: pre != Preconditioner::Mass,
            ..*h.scene.settings()
        };
        if let Err(e) = h.scene.set_settings(settings) {
            eprintln!("rt_loop: {e}");
            std::process::exit(2);
        }
    }
    let cg = h.scene.settings().cg_iterations;
    let pre = h.scene.settings().preconditioner.name();

    // Real-time set-up, each reported.
    let pinned = args.cpu.map(pin);
    let fifo = args.fifo.map(set_fifo);
    let ftz = args.ftz && set_ftz();
    // Timer slack: Linux lets a normal thread's timers fire up to 50 µs
    // late so it can batch wake-ups; 1 ns asks for the deadline itself.
    // SAFETY: a plain prctl on this thread.
    let slack =
        args.slack && unsafe { libc::prctl(libc::PR_SET_TIMERSLACK, 1u64, 0u64, 0u64, 0u64) } == 0;
    // SAFETY: plain flags; failure is reported, not fatal.
    let locked = args.mlock && unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } == 0;

    // Buffers written before the loop: no allocation and no first-touch
    // page fault inside it.
    let n = args.steps;
    // (`vec![0; n]` would be calloc'd pages, untouched until the loop
    // writes them: one fault per 4 KiB there, which `--no-prefault` shows.)
    let fill = if args.prefault { -1i64 } else { 0 };
    let mut step_ns = vec![fill; n];
    let mut wake_ns = vec![fill; n];
    if args.prefault {
        prefault_stack(256 * 1024);
    }

    // Load on the other core(s).
    let stop = Arc::new(AtomicBool::new(false));
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let mut loaders = Vec::new();
    if args.load {
        for c in 0..cores.max(2) - 1 {
            let stop = stop.clone();
            let avoid = args.cpu;
            loaders.push(std::thread::spawn(move || {
                if let Some(rt) = avoid {
                    let other = (0..cores).filter(|&k| k != rt).nth(c % (cores - 1).max(1));
                    if let Some(o) = other {
                        pin(o);
                    }
                }
                // Floating-point and memory work, like a compiler or a renderer.
                let mut v = vec![1.0f64; 1 << 20];
                let mut x = 1.0f64;
                while !stop.load(Ordering::Relaxed) {
                    for e in v.iter_mut() {
                        x = x * 1.000_000_1 + *e;
                        *e = x.sqrt();
                    }
                }
                std::hint::black_box(x);
            }));
        }
    }

    let period = (1.0e9 / args.rate).round() as i64;
    let spin = args.spin_us as i64 * 1000;
    let (ax, ay) = (h.axes[0], h.axes[1]);
    let omega = std::f32::consts::TAU; // one turn per second of simulated time
    let mut first = [0i64; 5];
    let mut misses = 0usize;
    let mut skipped = 0usize;
    let mut max_force = 0.0f32;
    let mut worst_inverted = 0u32;
    let u0 = usage();
    let t_start = Instant::now();
    let mut deadline = now_ns() + period;
    for i in 0..n {
        if deadline - spin > now_ns() {
            sleep_until(deadline - spin);
        }
        while now_ns() < deadline {
            std::hint::spin_loop();
        }
        let wake = now_ns();
        // `--still`: the tool holds its start, the body comes to rest.
        let t = if args.still {
            0.0
        } else {
            (i + 1) as f32 * 1.0e-3
        };
        let mut target = h.start;
        target[ax] += h.radius * (omega * t).sin();
        target[ay] += h.radius * (1.0 - (omega * t).cos());
        let stepped = match &mut h.press {
            Some(p) => p.step(&mut h.scene, i as u32 + 1),
            None => h.scene.step_haptic(target).map(|st| (st, st.tool_force)),
        };
        let (st, f) = match stepped {
            Ok(st) => st,
            Err(e) => {
                eprintln!("rt_loop: step {i}: {e}");
                std::process::exit(1);
            }
        };
        let end = now_ns();
        if i < 5 {
            first[i] = end - wake;
        }
        step_ns[i] = end - wake;
        wake_ns[i] = wake - deadline;
        max_force = max_force.max((f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt());
        worst_inverted = worst_inverted.max(st.inverted);
        if end > deadline + period {
            misses += 1;
        }
        deadline += period;
        while deadline < end {
            deadline += period;
            skipped += 1;
        }
    }
    let wall = t_start.elapsed().as_secs_f64();
    let u1 = usage();
    stop.store(true, Ordering::Relaxed);
    for l in loaders {
        let _ = l.join();
    }

    let s = summary(&mut step_ns);
    let w = summary(&mut wake_ns);
    let us = |x: i64| x as f64 / 1000.0;
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let load = load.split_whitespace().next().unwrap_or("?").to_owned();
    if args.json {
        println!(
            "{{\"scene\":\"{}\",\"cg\":{cg},\"preconditioner\":\"{pre}\",\"steps\":{n},\"rate\":{},\"load\":{},\"median_us\":{:.1},\"p99_us\":{:.1},\"p999_us\":{:.1},\"max_us\":{:.1},\"first_us\":{:.1},\"wake_p999_us\":{:.1},\"wake_max_us\":{:.1},\"misses\":{misses},\"skipped\":{skipped},\"minflt\":{},\"majflt\":{},\"nivcsw\":{},\"loadavg\":{load}}}",
            h.name,
            args.rate,
            args.load,
            us(s.median),
            us(s.p99),
            us(s.p999),
            us(s.max),
            us(first[0]),
            us(w.p999),
            us(w.max),
            u1.minflt - u0.minflt,
            u1.majflt - u0.majflt,
            u1.nivcsw - u0.nivcsw,
        );
        return;
    }
    println!("scene      {}, {cg} CG iterations ({pre}), dt 1 ms", h.name);
    println!(
        "loop       {n} steps at {} Hz in {wall:.1} s{}; load average {load}",
        args.rate,
        if args.load {
            ", other core(s) loaded"
        } else {
            ""
        }
    );
    println!(
        "set-up     pinned {:?}, SCHED_FIFO {:?}, timer slack 1 ns {slack}, mlockall {locked}, prefault {}, FTZ/DAZ {ftz}",
        pinned, fifo, args.prefault
    );
    println!(
        "step       median {:.1} µs, p99 {:.1} µs, p99.9 {:.1} µs, max {:.1} µs (first steps {:.0?} µs)",
        us(s.median),
        us(s.p99),
        us(s.p999),
        us(s.max),
        first.map(us)
    );
    println!(
        "wake-up    median {:.1} µs late, p99 {:.1} µs, p99.9 {:.1} µs, max {:.1} µs",
        us(w.median),
        us(w.p99),
        us(w.p999),
        us(w.max)
    );
    println!(
        "deadlines  {misses} missed of {n} ({:.3}%), {skipped} periods skipped",
        100.0 * misses as f64 / n as f64
    );
    println!(
        "in loop    {} minor / {} major page faults, {} voluntary / {} involuntary context switches",
        u1.minflt - u0.minflt,
        u1.majflt - u0.majflt,
        u1.nvcsw - u0.nvcsw,
        u1.nivcsw - u0.nivcsw
    );
    println!(
        "physics    max {} force {max_force:.3} N, most inverted elements {worst_inverted}, hash {:016x}",
        if h.press.is_some() { "probe" } else { "tool" },
        h.scene.state_hash()
    );
}
