//! Short versions of the reliability runs of docs/reliability.md, for CI:
//! a few sweep cases per body (the fast extremes) and a 20 000-step soak.
//! The full sweep and the million-step soak are the `sweep` and `soak`
//! binaries (`cargo run --release -p corofem-host-tests --bin sweep`).

use corofem::Method;
use corofem_host_tests::reliability::{self, Body, Case, RECOVERED};

/// Runs `cases` on `body` with `method` and checks each passes: finite, no
/// refused step, energy bounded by the tool's work, back within 1%.
fn sweep(body: &Body, method: Method, cases: &[Case]) {
    for &case in cases {
        corofem_host_tests::progress(
            "reliability",
            format_args!("{} {method:?} {case:?}", body.name),
        );
        let o = reliability::run_case(body, case, method, 200_000);
        eprintln!(
            "{} {method:?} {case:?}: {} steps, {:.0}% inverted, energy {:.2}× the work, recovery {:.1e} in {:.2} s",
            body.name,
            o.steps,
            100.0 * o.inverted,
            o.energy_ratio,
            o.recovery,
            o.recovery_time
        );
        assert!(o.passed, "{} {method:?} {case:?}: {}", body.name, o.note);
        assert!(o.recovery < RECOVERED);
    }
}

const NOMINAL: Case = Case {
    young: 3.0e4,
    poisson: 0.45,
    dt: 1.0e-3,
    cg: 10,
};

const fn young(young: f32) -> Case {
    Case { young, ..NOMINAL }
}

/// Cases of the full sweep that pass and run in well under a second each
/// (docs/reliability.md has the whole table, failures included).
#[test]
fn beam_and_slivers_survive_extremes() {
    let beam = reliability::beam();
    sweep(&beam, Method::Qr, &[young(0.0)]);
    sweep(&beam, Method::Polar, &[young(1.0e8), young(1.0e10)]);
    let slivers = reliability::sliver_beam();
    // The squashed layer is what the test is about.
    assert!(slivers.min_dihedral < 1.0, "{}", slivers.min_dihedral);
    // Every element inverted by a pull at dt = 0.05 s, E = 1e10 Pa, ν = 0.
    sweep(
        &slivers,
        Method::Qr,
        &[Case {
            young: 1.0e10,
            poisson: 0.0,
            dt: 0.05,
            cg: 200,
        }],
    );
    sweep(&slivers, Method::Polar, &[young(0.0), young(1.0e9)]);
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn liver_and_bunny_survive_extremes() {
    let (liver, bunny) = (reliability::liver(), reliability::bunny());
    sweep(
        &liver,
        Method::Qr,
        &[
            NOMINAL,
            young(0.0),
            young(1.0e10),
            Case {
                poisson: 0.0,
                ..NOMINAL
            },
        ],
    );
    sweep(&bunny, Method::Polar, &[young(0.0)]);
}

/// The limit the sweep found: QR's elastic forces are not conservative, and
/// on a soft liver (E = 100 Pa) with half its elements inverted and light
/// damping their energy grows without bound (docs/reliability.md). The
/// polar method, whose forces are the gradient of its energy, recovers the
/// same case; the QR state stays finite (steps are refused once it would
/// overflow).
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn soft_liver_limit_of_qr_and_polar_recovery() {
    let liver = reliability::liver();
    let polar = reliability::run_case(&liver, young(1.0e2), Method::Polar, 200_000);
    assert!(polar.passed, "{}", polar.note);
    let qr = reliability::run_case(&liver, young(1.0e2), Method::Qr, 20_000);
    eprintln!(
        "QR, E = 100 Pa: energy {:.1e}× the tool's work, {} refused steps",
        qr.energy_ratio, qr.refused
    );
    assert!(qr.finite);
}

/// The same soft liver with `QrInvertible`: its inverted elements turn by
/// the rotation closest to their deformation gradient, whose forces are an
/// energy's, and the liver comes back within 1% (measured: 6.25 s after
/// the release, energy 0.79 of the tool's work), where `Qr` comes to rest
/// folded (0.63 of the diagonal, with the energy guard) or blows up
/// (without it).
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn soft_liver_recovers_with_qr_invertible() {
    let liver = reliability::liver();
    let o = reliability::run_case(&liver, young(1.0e2), Method::QrInvertible, 20_000);
    eprintln!(
        "QrInvertible, E = 100 Pa: {}, recovery error {:.1e} in {:.2} s, energy {:.2}× the tool's work, {:.0}% inverted at most",
        if o.passed { "pass" } else { &o.note },
        o.recovery,
        o.recovery_time,
        o.energy_ratio,
        100.0 * o.inverted
    );
    assert!(o.passed, "{}", o.note);
}

/// 20 000 steps of random drags of the liver (the long run is 1 000 000)
/// with `method`, checked for what every method must do: no refused step,
/// everything finite.
fn short_soak(method: Method) -> reliability::Soak {
    corofem_host_tests::progress(
        "reliability",
        format_args!("{method:?}: a 20,000-step soak of the liver"),
    );
    let liver = reliability::liver();
    let s = reliability::soak(&liver, method, 20_000, 10_000, 2005);
    eprintln!("{method:?}: {s:?}");
    assert!(s.finite, "{s:?}");
    assert_eq!(s.refused, 0, "{s:?}");
    assert!(s.checks >= 1, "{s:?}");
    assert!(s.drags >= 10, "{s:?}");
    s
}

/// The short soak with QR. Its shape after the 10 s rest is printed, not
/// asserted: QR can leave the liver tangled through its pins, at rest in
/// another equilibrium (docs/reliability.md, finding 3). Over seeds 1–20
/// and 2005, 5 of 21 runs end tangled (shape error 0.18–0.95 of the
/// diagonal, this seed not among them) with the element order of
/// `block::slot`; 4 of 13 with the order before it, and 3 of 21 with a
/// trial order (this seed among them): which seeds tangle depends on the
/// bits, how often does not.
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn liver_soak_short() {
    short_soak(Method::Qr);
}

/// The same drags with the polar method, which must also bring the liver
/// back within 1% of its settled shape after the 10 s rest (polar came back
/// at every check of the long soak, where QR stayed tangled:
/// docs/reliability.md).
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn liver_soak_short_polar_recovers() {
    let s = short_soak(Method::Polar);
    assert!(s.worst_recovery < RECOVERED, "{s:?}");
}
