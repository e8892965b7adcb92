//! A 1 kHz haptic loop with its worst case measured.
//!
//! ```text
//! cargo run --release --example rt_loop -- [--scene liver|box10k|FILE.tetmesh]
//!     [--steps 100000] [--rate 1000] [--cg 10] [--preconditioner NAME]
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
use corofem_core::{BoxMesh, BuildOptions, Material, Preconditioner, Settings};

struct Args {
    scene: String,
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
}

fn liver(path: &str, cg: u32) -> Result<Haptic, String> {
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
    Ok(Haptic {
        name: format!("liver ({} nodes, {} tets)", nodes.len(), tets.len()),
        start: s.tool_target(),
        scene: s,
        radius: 0.02,
        axes: [0, 1],
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
    let liver_path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/meshes/sofa_liver.tetmesh")
        .to_string_lossy()
        .into_owned();
    let built = match args.scene.as_str() {
        "liver" => liver(&liver_path, args.cg.unwrap_or(10)),
        "box10k" => box10k(args.cg.unwrap_or(5)),
        path => liver(path, args.cg.unwrap_or(10)),
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
        let st = match h.scene.step_haptic(target) {
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
        let f = st.tool_force;
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
        "physics    max tool force {max_force:.3} N, most inverted elements {worst_inverted}, hash {:016x}",
        h.scene.state_hash()
    );
}
