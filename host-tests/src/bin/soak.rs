//! The soak of docs/reliability.md: the liver dragged at random by the tool
//! for a million steps, checked for finiteness every 1000 steps and for
//! recovery (released, back within 1% of its hanging shape) every 100 000.
//!
//! ```text
//! cargo run --release -p corofem-host-tests --bin soak -- [STEPS [CHECK_EVERY [SEED [METHOD]]]] [--write docs/reliability.md]
//! ```
//!
//! METHOD is `qr` (default) or `polar`.

use corofem_host_tests::reliability;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let write = args.iter().position(|a| a == "--write").map(|i| {
        let file = args.get(i + 1).cloned().expect("--write FILE");
        args.drain(i..i + 2);
        file
    });
    let num = |i: usize, default: u64| {
        args.get(i)
            .map_or(default, |a| a.parse().expect("a number"))
    };
    let steps = num(0, 1_000_000);
    let check_every = num(1, 100_000);
    let seed = num(2, 2005);
    let method = args.get(3).map_or(corofem::Method::Qr, |m| {
        corofem::Method::from_name(m)
            .filter(|m| m.is_compiled())
            .expect("qr, polar, linear or qr-rest-b")
    });
    if corofem_host_tests::shared_meshes().is_none() {
        eprintln!("SKIPPED: ../shared/meshes not found");
        return;
    }
    let liver = reliability::liver();
    let s = reliability::soak(&liver, method, steps, check_every, seed);
    let table = format!(
        "| steps | drags | refused steps | all finite | max inverted | max tool force (N) | max kinetic energy (J) | recovery checks | worst recovery error | median step (µs) | wall (s) |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n\
         | {} | {} | {} | {} | {:.0}% | {:.3e} | {:.3e} | {} | {:.1e} | {:.1} | {:.0} |\n\n\
         Method {}, seed {seed}; command: `cargo run --release -p corofem-host-tests --bin soak -- {steps} {check_every} {seed} {}`.",
        s.steps,
        s.drags,
        s.refused,
        if s.finite { "yes" } else { "**no**" },
        100.0 * s.inverted,
        s.max_force,
        s.max_kinetic,
        s.checks,
        s.worst_recovery,
        s.step_us,
        s.wall,
        method.name(),
        method.name()
    );
    println!("{table}");
    if let Some(file) = write {
        let doc = std::fs::read_to_string(&file).unwrap_or_default();
        let section = format!("soak-{}", method.name());
        std::fs::write(&file, reliability::replace_section(&doc, &section, &table))
            .expect("write the report");
    }
    assert!(
        s.finite && s.refused == 0 && s.worst_recovery < reliability::RECOVERED,
        "{s:?}"
    );
}
