//! Bad input: every error variant is triggered, and the scene is unchanged
//! after each (same state hash, counts, settings and fixed nodes).

use corofem::{
    BuildOptions, Error, Material, Parameter, Plane, Settings, StaticScene, StaticSettings,
    StepError,
};
use corofem_host_tests::box_mesh;

corofem::capacity! {
    /// A grab and a load slot for every node.
    struct SmallSlots { nodes: 64, elements: 128, grabs: 64, loads: 64 }
}
/// The scene of the tests.
type Small = StaticScene<SmallSlots>;

/// A built, stepped scene and a fingerprint of everything observable.
fn scene() -> Small {
    scene_of(&Material::default())
}

fn scene_of(material: &Material) -> Small {
    let mesh = box_mesh([2.0, 1.0, 1.0], [2, 1, 1], 6);
    let mut s = Small::new();
    s.build(&mesh.nodes, &mesh.tets, material, BuildOptions::default())
        .unwrap();
    s.fix_nodes(&[0]).unwrap();
    s.set_force(5, [1.0, 2.0, 3.0]).unwrap();
    for _ in 0..3 {
        s.step().unwrap();
    }
    s
}

/// State hash, counts, settings, fixed flags, rest positions and ground.
type Fingerprint = (
    u64,
    usize,
    usize,
    Settings,
    Vec<bool>,
    Vec<[f32; 3]>,
    Option<Plane>,
);

fn fingerprint(s: &Small) -> Fingerprint {
    let fixed = (0..s.node_count() as u32).map(|i| s.is_fixed(i)).collect();
    let rest = (0..s.node_count() as u32)
        .map(|i| s.rest_position(i).unwrap())
        .collect();
    (
        s.state_hash(),
        s.node_count(),
        s.element_count(),
        *s.settings(),
        fixed,
        rest,
        s.ground(),
    )
}

/// Asserts `op` fails with `want` and changes nothing.
fn rejects<T: std::fmt::Debug>(want: Error, op: impl FnOnce(&mut Small) -> Result<T, Error>) {
    let mut s = scene();
    let before = fingerprint(&s);
    let got = op(&mut s);
    assert_eq!(got.err(), Some(want));
    assert_eq!(fingerprint(&s), before, "{want:?} changed the scene");
    assert!(!want.to_string().is_empty());
}

const TET: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];

#[test]
fn every_build_error_names_the_culprit_and_changes_nothing() {
    let m = Material::default();
    let o = BuildOptions::default();
    let many = vec![[0.0f32; 3]; 65];
    rejects(
        Error::TooManyNodes {
            count: 65,
            capacity: 64,
        },
        |s| s.build(&many, &[[0, 1, 2, 3]], &m, o),
    );
    rejects(
        Error::TooManyElements {
            count: 129,
            capacity: 128,
        },
        |s| s.build(&TET, &[[0, 1, 2, 3]; 129], &m, o),
    );
    rejects(Error::NoElements, |s| s.build(&TET, &[], &m, o));
    let mut nan = TET;
    nan[2][1] = f32::NAN;
    rejects(Error::NonFiniteCoordinate { node: 2 }, |s| {
        s.build(&nan, &[[0, 1, 2, 3]], &m, o)
    });
    let mut inf = TET;
    inf[3][0] = f32::INFINITY;
    rejects(Error::NonFiniteCoordinate { node: 3 }, |s| {
        s.build(&inf, &[[0, 1, 2, 3]], &m, o)
    });
    rejects(
        Error::NodeIndexOutOfRange {
            element: 1,
            node: 7,
        },
        |s| s.build(&TET, &[[0, 1, 2, 3], [0, 1, 2, 7]], &m, o),
    );
    rejects(
        Error::RepeatedNode {
            element: 0,
            node: 1,
        },
        |s| s.build(&TET, &[[0, 1, 1, 3]], &m, o),
    );
    let flat = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    rejects(Error::DegenerateElement { element: 0 }, |s| {
        s.build(&flat, &[[0, 1, 2, 3]], &m, o)
    });
    let same = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    rejects(Error::DegenerateElement { element: 0 }, |s| {
        s.build(&same, &[[0, 1, 2, 3]], &m, o)
    });
    rejects(Error::InvertedElement { element: 0 }, |s| {
        s.build(&TET, &[[0, 2, 1, 3]], &m, o)
    });
    let five = [TET[0], TET[1], TET[2], TET[3], [5.0, 5.0, 5.0]];
    rejects(Error::UnusedNode { node: 4 }, |s| {
        s.build(&five, &[[0, 1, 2, 3]], &m, o)
    });
    for (bad, parameter) in [
        (Material { young: -1.0, ..m }, Parameter::Young),
        (
            Material {
                young: f32::NAN,
                ..m
            },
            Parameter::Young,
        ),
        (Material { poisson: 0.5, ..m }, Parameter::Poisson),
        (Material { poisson: -0.1, ..m }, Parameter::Poisson),
        (Material { density: 0.0, ..m }, Parameter::Density),
        (
            Material {
                density: f32::INFINITY,
                ..m
            },
            Parameter::Density,
        ),
    ] {
        rejects(Error::InvalidParameter { parameter }, |s| {
            s.build(&TET, &[[0, 1, 2, 3]], &bad, o)
        });
    }
}

#[test]
fn reorientation_fixes_negative_tetrahedra_when_asked() {
    let mut s = Small::new();
    s.build(
        &TET,
        &[[0, 2, 1, 3]],
        &Material::default(),
        BuildOptions { reorient: true },
    )
    .unwrap();
    assert_eq!(s.element_nodes(0), Some([0, 2, 3, 1]));
    assert!(s.rest_volume(0).unwrap() > 0.0);
}

#[test]
fn every_setter_error_changes_nothing() {
    rejects(Error::NodeOutOfRange { node: 18 }, |s| {
        s.fix_nodes(&[1, 18])
    });
    rejects(Error::NodeOutOfRange { node: 99 }, |s| {
        s.set_force(99, [0.0; 3])
    });
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::Force,
        },
        |s| s.set_force(1, [f32::NAN, 0.0, 0.0]),
    );
    rejects(Error::NodeOutOfRange { node: 40 }, |s| {
        s.grab(&[2, 40], 10.0)
    });
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::ToolNodes,
        },
        |s| s.grab(&[], 10.0),
    );
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::ToolStiffness,
        },
        |s| s.grab(&[2], -1.0),
    );
    rejects(Error::ElementOutOfRange { element: 12 }, |s| {
        s.set_young(12, 1.0)
    });
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::Young,
        },
        |s| s.set_young(0, -5.0),
    );
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::Young,
        },
        |s| s.set_young_all(f32::INFINITY),
    );
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::Poisson,
        },
        |s| s.set_poisson(0.7),
    );
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::Ground,
        },
        |s| {
            s.set_ground(Some(Plane {
                normal: [0.0; 3],
                offset: 0.0,
            }))
        },
    );
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::Positions,
        },
        |s| s.set_positions(&[[0.0; 3]; 3]),
    );
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::Velocities,
        },
        |s| {
            let mut v = vec![[0.0f32; 3]; s.node_count()];
            v[4][1] = f32::NAN;
            s.set_velocities(&v)
        },
    );
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::Displacements,
        },
        |s| s.set_displacements(&[]),
    );
    for (bad, parameter) in [
        (
            Settings {
                dt: 0.0,
                ..Settings::default()
            },
            Parameter::Dt,
        ),
        (
            Settings {
                dt: f32::NAN,
                ..Settings::default()
            },
            Parameter::Dt,
        ),
        (
            Settings {
                cg_iterations: 0,
                ..Settings::default()
            },
            Parameter::CgIterations,
        ),
        (
            Settings {
                cg_tolerance: -1.0,
                ..Settings::default()
            },
            Parameter::CgTolerance,
        ),
        (
            Settings {
                rayleigh_mass: -1.0,
                ..Settings::default()
            },
            Parameter::RayleighMass,
        ),
        (
            Settings {
                rayleigh_stiffness: f32::NAN,
                ..Settings::default()
            },
            Parameter::RayleighStiffness,
        ),
        (
            Settings {
                gravity: [0.0, f32::INFINITY, 0.0],
                ..Settings::default()
            },
            Parameter::Gravity,
        ),
    ] {
        rejects(Error::InvalidParameter { parameter }, |s| {
            s.set_settings(bad)
        });
    }
    rejects(
        Error::InvalidParameter {
            parameter: Parameter::ForcesOut,
        },
        |s| s.elastic_forces(&mut [[0.0; 3]; 2]),
    );
}

#[test]
fn static_solve_errors() {
    let d = StaticSettings::default();
    for (bad, parameter) in [
        (
            StaticSettings {
                cg_iterations: 0,
                ..d
            },
            Parameter::StaticCgIterations,
        ),
        (
            StaticSettings {
                cg_tolerance: f32::NAN,
                ..d
            },
            Parameter::StaticCgTolerance,
        ),
        (
            StaticSettings {
                tolerance: -1.0,
                ..d
            },
            Parameter::StaticTolerance,
        ),
        (
            StaticSettings {
                update_tolerance: -1.0,
                ..d
            },
            Parameter::StaticUpdateTolerance,
        ),
    ] {
        rejects(Error::InvalidParameter { parameter }, |s| {
            s.solve_static(&bad, |_| {})
        });
    }
    rejects(Error::Unconstrained, |s| {
        s.unfix_all();
        let r = s.solve_static(&StaticSettings::default(), |_| {});
        s.fix_nodes(&[0]).unwrap();
        r
    });
    let mut empty = Small::new();
    assert_eq!(
        empty.solve_static(&StaticSettings::default(), |_| {}).err(),
        Some(Error::NotBuilt)
    );
    // A load on a body so light that the update overflows f32.
    let mut s = scene_of(&Material {
        density: 1e-9,
        ..Material::default()
    });
    s.set_force(7, [3.0e38, 3.0e38, 3.0e38]).unwrap();
    s.set_force(8, [3.0e38, 3.0e38, 3.0e38]).unwrap();
    let before = s.state_hash();
    assert_eq!(
        s.solve_static(&StaticSettings::default(), |_| {}).err(),
        Some(Error::StaticDiverged)
    );
    // The solve keeps the last finite iterate; here the very first update overflowed.
    assert_eq!(s.state_hash(), before);
}

/// The tool target's setter returns `Error`, as every setter does; a step
/// given a bad target returns the step's error. Neither moves the target.
#[test]
fn a_non_finite_tool_target_is_refused_by_the_setter_and_the_step() {
    let mut s = scene();
    s.grab(&[10, 11], 100.0).unwrap();
    let target = s.tool_target();
    let before = fingerprint(&s);
    assert_eq!(
        s.set_tool_target([0.0, f32::NAN, 0.0]),
        Err(Error::InvalidParameter {
            parameter: Parameter::ToolTarget
        })
    );
    assert_eq!(
        s.step_haptic([f32::INFINITY, 0.0, 0.0]),
        Err(StepError::NonFiniteInput)
    );
    assert_eq!(s.tool_target(), target);
    assert_eq!(fingerprint(&s), before);
    s.set_tool_target([0.1, 0.2, 0.3]).unwrap();
    assert_eq!(s.tool_target(), [0.1, 0.2, 0.3]);
}

/// Each parameter error says which parameter and what a valid value is;
/// no two say the same.
#[test]
fn parameter_errors_say_what_is_valid() {
    use Parameter::*;
    let all = [
        Young,
        Poisson,
        Density,
        Dt,
        CgIterations,
        CgTolerance,
        RayleighMass,
        RayleighStiffness,
        Gravity,
        Force,
        Positions,
        Displacements,
        Velocities,
        ToolNodes,
        ToolStiffness,
        ToolTarget,
        Ground,
        StaticCgIterations,
        StaticCgTolerance,
        StaticTolerance,
        StaticUpdateTolerance,
        ForcesOut,
        ProductInput,
        ProductOut,
        Cells,
        Size,
        TetsPerCell,
    ];
    let messages: std::collections::BTreeSet<String> = all
        .iter()
        .map(|&parameter| Error::InvalidParameter { parameter }.to_string())
        .collect();
    assert_eq!(messages.len(), all.len());
    for m in &messages {
        assert!(m.starts_with("invalid ") && m.contains(": "), "{m}");
    }
    assert_eq!(
        Error::InvalidParameter { parameter: Dt }.to_string(),
        "invalid time step `dt`: it must be finite and > 0 s"
    );
    assert_eq!(
        Error::MethodNotCompiled {
            method: corofem::Method::Polar
        }
        .to_string(),
        "element method `polar` is not compiled into this build (corofem feature `polar`)"
    );
}

#[test]
fn step_errors_leave_the_state_unchanged() {
    // Light enough that a huge force overflows the velocity.
    let mut s = scene_of(&Material {
        density: 1e-9,
        ..Material::default()
    });
    s.grab(&[10, 11], 100.0).unwrap();
    let before = s.state_hash();
    let target = s.tool_target();
    assert_eq!(
        s.step_haptic([f32::NAN, 0.0, 0.0]).err(),
        Some(StepError::NonFiniteInput)
    );
    assert_eq!(
        s.step_haptic([0.0, f32::INFINITY, 0.0]).err(),
        Some(StepError::NonFiniteInput)
    );
    assert_eq!(s.state_hash(), before);
    assert_eq!(s.tool_target(), target);
    s.set_force(7, [3.0e38, 0.0, 0.0]).unwrap();
    s.set_force(8, [3.0e38, 0.0, 0.0]).unwrap();
    assert_eq!(s.step().err(), Some(StepError::Diverged));
    assert_eq!(s.state_hash(), before);
    // And it keeps working once the input is sane again.
    s.clear_forces();
    s.step().unwrap();
    assert!(s.positions().all(|p| p.iter().all(|v| v.is_finite())));
}

/// A body that starts below the ground is refused by the first step after
/// each placement (the ground set, the body built, moved, reset or freed),
/// naming its first node below, with nothing changed; one resting on the
/// plane steps, and so does a body the steps themselves take into it.
#[test]
fn a_body_below_the_ground_is_refused() {
    // The 2 × 1 × 1 m box spans z in [0, 1]; node 0 is fixed.
    let mut s = scene();
    let lowest_free = (1..s.node_count() as u32)
        .filter(|&i| !s.is_fixed(i))
        .min_by(|&a, &b| s.position(a).unwrap()[2].total_cmp(&s.position(b).unwrap()[2]))
        .unwrap();
    let floor = |offset| {
        Some(Plane {
            normal: [0.0, 0.0, 1.0],
            offset,
        })
    };
    let z = s.position(lowest_free).unwrap()[2];
    s.set_ground(floor(z + 1e-3)).unwrap();
    let before = fingerprint(&s);
    match s.step() {
        Err(StepError::BelowGround { node }) => {
            assert!(s.position(node).unwrap()[2] < z + 1e-3);
            assert!(!s.is_fixed(node));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(fingerprint(&s), before);
    assert!(!StepError::BelowGround { node: 1 }.to_string().is_empty());
    // On the plane: it steps, and goes on stepping as it sinks and is
    // pushed out (the check is once per placement).
    s.set_ground(floor(z)).unwrap();
    s.set_settings(Settings {
        gravity: [0.0, 0.0, -200.0],
        ..*s.settings()
    })
    .unwrap();
    for _ in 0..50 {
        s.step().unwrap();
    }
    // Each placement checks again.
    let rest: Vec<[f32; 3]> = (0..s.node_count() as u32)
        .map(|i| s.rest_position(i).unwrap())
        .collect();
    let sunk: Vec<[f32; 3]> = rest.iter().map(|p| [p[0], p[1], p[2] - 0.5]).collect();
    s.set_positions(&sunk).unwrap();
    assert!(matches!(s.step(), Err(StepError::BelowGround { .. })));
    s.reset_state();
    s.step().unwrap();
    s.set_displacements(&vec![[0.0, 0.0, -0.5]; s.node_count()])
        .unwrap();
    assert!(matches!(s.step(), Err(StepError::BelowGround { .. })));
    s.set_ground(None).unwrap();
    s.step().unwrap();
    // Fixed nodes may lie below it; freed, they may not.
    s.reset_state();
    s.set_ground(floor(z + 1e-3)).unwrap();
    let below: Vec<u32> = (0..s.node_count() as u32)
        .filter(|&i| s.position(i).unwrap()[2] < z + 1e-3)
        .collect();
    s.fix_nodes(&below).unwrap();
    s.step().unwrap();
    s.unfix_all();
    assert!(matches!(s.step(), Err(StepError::BelowGround { .. })));
}

/// Found by `.ci/fuzz.sh` (build_scene): a tetrahedron whose node d lies
/// 2.8e38 m away has finite edges, volume and mass, but its 6V-scaled
/// gradients (products of two coordinates) overflow, so even the rest state
/// gave 0 · ∞ = NaN and the first step diverged. It is now refused.
#[test]
fn regression_element_with_overflowing_gradients_is_refused() {
    let nodes = [
        [0.0, 0.0, 0.0],
        [-0.5, -0.5, -0.5],
        [225831060000.0, -2.7690685e38, 0.0],
        [1.0, 1.5, -1.0],
    ];
    let material = Material {
        young: 0.0,
        poisson: 0.0,
        density: 0.0125,
    };
    refused_or_rest_is_equilibrium(&nodes, [3, 0, 2, 1], &material);
}

/// Found by the CI fuzz run after the fix above: a sliver with one node at
/// z = f32::MAX had finite local gradients, but its world gradients `Rᵀ(β,
/// γ, δ)` (sums of three products near f32::MAX) overflowed, and again the
/// first step from rest diverged. `build` now checks the gradients the step's
/// own kernel computes.
#[test]
fn regression_element_with_overflowing_world_gradients_is_refused() {
    let nodes = [
        [-1.1563734e-15, 215657140.0, 3.4028235e38],
        [2.3011998e-30, -0.2731, -0.0013020833],
        [1.0, -1.0, -1.0],
        [0.0, 0.0, -2.1896627e-5],
    ];
    let material = Material {
        young: 618750000.0,
        poisson: 0.49804688,
        density: 0.896875,
    };
    refused_or_rest_is_equilibrium(&nodes, [3, 1, 2, 0], &material);
}

/// Building the single tetrahedron either fails with an error naming it, or
/// gives a rest state that one step leaves exactly where it is.
fn refused_or_rest_is_equilibrium(nodes: &[[f32; 3]], tet: [u32; 4], material: &Material) {
    for reorient in [false, true] {
        let mut s = Small::new();
        match s.build(nodes, &[tet], material, BuildOptions { reorient }) {
            Err(e) => assert!(
                matches!(
                    e,
                    Error::DegenerateElement { element: 0 } | Error::InvertedElement { element: 0 }
                ),
                "{e:?}"
            ),
            Ok(()) => {
                let before = s.state_hash();
                s.set_settings(Settings {
                    gravity: [0.0; 3],
                    ..s.default_settings()
                })
                .unwrap();
                assert!(s.step().is_ok());
                assert_eq!(s.state_hash(), before);
            }
        }
    }
}

/// A built tetrahedron whose node 0 sits at z = f32::MAX: `build` accepts it
/// (its frame is regular: the far node is `d`), so positions and
/// displacements near the top of f32 are reachable.
fn far_node_scene() -> Small {
    let nodes = [
        [-1.1563734e-15, 215657140.0, 3.4028235e38],
        [2.302e-30, -0.2731, 7.17e-43],
        [0.0, 0.0, 0.0],
        [0.0, 0.0, -2.1896627e-5],
    ];
    let material = Material {
        young: 618750000.0,
        poisson: 0.49804688,
        density: 8968.75,
    };
    let mut s = Small::new();
    s.build(&nodes, &[[3, 1, 2, 0]], &material, BuildOptions::default())
        .unwrap();
    s
}

/// Found by the CI fuzz run: a node at z = f32::MAX whose displacement stays
/// finite under an absurd gravity (2.7e36 m/s²) while its position `x₀ + u`
/// overflows. The step used to check only `u` and applied it; it now refuses
/// the step and leaves the state unchanged.
#[test]
fn regression_step_whose_position_overflows_is_refused() {
    let mut s = far_node_scene();
    s.set_settings(Settings {
        method: corofem::Method::Linear,
        dt: 0.0061875004,
        cg_iterations: 7,
        gravity: [-7.668923e-16, -3.0316488e-13, 2.655521e36],
        ..s.default_settings()
    })
    .unwrap();
    let mut refused = 0;
    for _ in 0..4 {
        let before = s.state_hash();
        match s.step() {
            Ok(_) => assert!(s.positions().flatten().all(f32::is_finite)),
            Err(e) => {
                assert_eq!(e, StepError::Diverged);
                assert_eq!(s.state_hash(), before, "a refused step changed the state");
                refused += 1;
            }
        }
    }
    // Without the check the first step was applied with an infinite position.
    assert!(refused > 0, "the overflowing step was not refused");
}

/// The setters check what they imply: a finite position whose displacement
/// `p − x₀` overflows, or a finite displacement whose position `x₀ + u`
/// overflows, is refused with the scene unchanged.
#[test]
fn setters_refuse_values_whose_position_or_displacement_overflows() {
    let mut s = far_node_scene();
    let before = s.state_hash();
    let mut positions: Vec<[f32; 3]> = s.positions().collect();
    positions[0][2] = -f32::MAX; // −MAX − x₀ = −2 MAX: overflows
    assert_eq!(
        s.set_positions(&positions),
        Err(Error::InvalidParameter {
            parameter: Parameter::Positions
        })
    );
    let mut displacements = vec![[0.0f32; 3]; 4];
    displacements[0][2] = f32::MAX; // x₀ + MAX = 2 MAX: overflows
    assert_eq!(
        s.set_displacements(&displacements),
        Err(Error::InvalidParameter {
            parameter: Parameter::Displacements
        })
    );
    assert_eq!(s.state_hash(), before);
    // Large but representable values are accepted.
    displacements[0][2] = -f32::MAX;
    assert_eq!(s.set_displacements(&displacements), Ok(()));
    assert!(s.positions().flatten().all(f32::is_finite));
}
