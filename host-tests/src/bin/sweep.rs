//! The extreme-parameter sweep of docs/reliability.md: the liver, the bunny,
//! a beam and a beam with slivers, each pulled through itself, released and
//! damped, for Young's modulus 0 to 1e10 Pa, Poisson ratio 0 to 0.499, time
//! step 1e-5 to 0.05 s and 1 to 200 CG iterations.
//!
//! ```text
//! cargo run --release -p corofem-host-tests --bin sweep -- [--write docs/reliability.md] [BODY...]
//! ```
//!
//! BODY is any of `liver`, `bunny`, `beam`, `slivers` (default: all). With
//! `--write FILE` the tables replace the `sweep-BODY` sections of FILE.
//! Each case runs with the default method and solver settings but its CG
//! budget; `COROFEM_SWEEP_METHOD`, `COROFEM_SWEEP_PRECONDITIONER`,
//! `COROFEM_SWEEP_WARM_START` and `COROFEM_SWEEP_ENERGY_GUARD` replace
//! them, `COROFEM_SWEEP_MAX_STEPS` the recovery budget, and
//! `COROFEM_SWEEP_POLAR=0` skips the polar re-run of a failed case.

use corofem::Method;
use corofem_host_tests::reliability::{self, Body, Outcome};

fn print_outcome(body: &Body, what: &str, o: &Outcome) {
    let c = o.case;
    eprintln!(
        "{} {what} {}: E {:.0e} ν {} dt {:.0e} CG {}: {} steps, inverted {:.0}%, energy ratio {:.2e}, recovery {:.1e} in {:.2} s, {:.1} s wall: {}",
        body.name,
        o.method.name(),
        c.young,
        c.poisson,
        c.dt,
        c.cg,
        o.steps,
        100.0 * o.inverted,
        o.energy_ratio,
        o.recovery,
        o.recovery_time,
        o.wall,
        if o.passed { "pass" } else { &o.note }
    );
}

/// Recovery budget in steps (10 s of simulated time at dt = 1e-5 s; the
/// slowest recovering case, E = 100 Pa, needs about that).
const MAX_RECOVERY_STEPS: u64 = 1_000_000;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let write = args.iter().position(|a| a == "--write").map(|i| {
        let file = args.get(i + 1).cloned().expect("--write FILE");
        args.drain(i..i + 2);
        file
    });
    // `--case E NU DT CG`: only this case (with COROFEM_SWEEP_VERBOSE=1 to
    // watch its recovery).
    let only = args.iter().position(|a| a == "--case").map(|i| {
        let v: Vec<String> = args.drain(i..i + 5).skip(1).collect();
        let f = |k: usize| v[k].parse::<f32>().expect("a number");
        reliability::Case {
            young: f(0),
            poisson: f(1),
            dt: f(2),
            cg: v[3].parse().expect("a whole number"),
        }
    });
    // `COROFEM_SWEEP_MAX_STEPS`: a smaller recovery budget for a quicker run.
    let budget = std::env::var("COROFEM_SWEEP_MAX_STEPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(MAX_RECOVERY_STEPS);
    let wanted = |name: &str| args.is_empty() || args.iter().any(|a| a == name);
    let mut bodies: Vec<(&str, Body)> = Vec::new();
    let meshes = corofem_host_tests::shared_meshes().is_some();
    if !meshes {
        eprintln!("../shared/meshes not found: the liver and the bunny are left out");
    }
    if wanted("liver") && meshes {
        bodies.push(("liver", reliability::liver()));
    }
    if wanted("bunny") && meshes {
        bodies.push(("bunny", reliability::bunny()));
    }
    if wanted("beam") {
        bodies.push(("beam", reliability::beam()));
    }
    if wanted("slivers") {
        bodies.push(("slivers", reliability::sliver_beam()));
    }
    // `COROFEM_SWEEP_METHOD=qr` (or another method's name) sweeps that
    // method instead of the default one.
    let method = std::env::var("COROFEM_SWEEP_METHOD").map_or(Method::DEFAULT, |m| {
        Method::from_name(&m).unwrap_or_else(|| panic!("COROFEM_SWEEP_METHOD: no method {m:?}"))
    });
    let rerun = std::env::var("COROFEM_SWEEP_POLAR").map_or(true, |v| v != "0");
    let (mut total, mut passed, mut rescued) = (0, 0, 0);
    for (key, body) in &bodies {
        let mut outcomes = Vec::new();
        let cases = match only {
            Some(c) => vec![("case", c)],
            None => reliability::sweep_cases(),
        };
        for (what, case) in cases {
            let o = reliability::run_case(body, case, method, budget);
            print_outcome(body, what, &o);
            total += 1;
            passed += usize::from(o.passed);
            // Where the method fails, the same case with the polar method
            // (`COROFEM_SWEEP_POLAR=0`: not).
            let polar = (!o.passed && rerun).then(|| {
                let p = reliability::run_case(body, case, Method::Polar, budget);
                print_outcome(body, what, &p);
                rescued += usize::from(p.passed);
                p
            });
            outcomes.push((what, o, polar));
        }
        let table = reliability::table(body, &outcomes);
        println!("{table}");
        if let Some(file) = &write {
            let doc = std::fs::read_to_string(file).unwrap_or_default();
            let doc = reliability::replace_section(&doc, &format!("sweep-{key}"), &table);
            std::fs::write(file, doc).expect("write the report");
        }
    }
    if rerun {
        println!(
            "sweep: {total} cases, {passed} passed with {}, {rescued} of the {} others pass with polar",
            method.name(),
            total - passed
        );
    } else {
        println!(
            "sweep: {total} cases, {passed} passed with {} (no polar re-runs)",
            method.name()
        );
    }
}
