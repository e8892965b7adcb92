//! Stepping with arbitrary inputs: a small distorted box, then any sequence
//! of API calls with any values (NaN and infinities included). After every
//! call the state is finite; a refused call leaves the scene unchanged
//! (a diverged static solve keeps its last finite iterate, as documented).

#![no_main]

mod common;

use arbitrary::{Result, Unstructured};
use corofem::VecScene;
use corofem::{BoxMesh, BuildOptions, Error, StaticSettings};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});

fn scene(u: &mut Unstructured) -> Result<Option<VecScene>> {
    let b = BoxMesh {
        size: [
            common::magnitude(u, -3, 3)?,
            common::magnitude(u, -3, 3)?,
            common::magnitude(u, -3, 3)?,
        ],
        cells: [
            u.int_in_range(1u32..=3)?,
            u.int_in_range(1u32..=2)?,
            u.int_in_range(1u32..=2)?,
        ],
        tets_per_cell: *u.choose(&[5u8, 6])?,
    };
    let mut nodes = vec![[0.0f32; 3]; b.node_count()];
    let mut tets = vec![[0u32; 4]; b.tet_count()];
    b.generate(&mut nodes, &mut tets).unwrap();
    let jitter = f32::from(u.arbitrary::<u8>()?) / 255.0 * 0.2;
    let h = [0, 1, 2].map(|k| b.size[k] / b.cells[k] as f32);
    for p in &mut nodes {
        for k in 0..3 {
            p[k] += jitter * h[k] * (f32::from(u.arbitrary::<i8>()?) / 128.0);
        }
    }
    let offset = if u.ratio(1u8, 8)? {
        common::magnitude(u, 2, 7)?
    } else {
        0.0
    };
    for p in &mut nodes {
        p[0] += offset;
    }
    let material = common::material(u)?;
    let mut s = corofem::VecScene::with_capacity(nodes.len(), tets.len());
    Ok(
        s.build(&nodes, &tets, &material, BuildOptions { reorient: true })
            .ok()
            .map(|()| s),
    )
}

fn run(u: &mut Unstructured) -> Result<()> {
    let Some(mut s) = scene(u)? else {
        return Ok(());
    };
    let n = s.node_count();
    let e = s.element_count();
    let ids = |u: &mut Unstructured| -> Result<Vec<u32>> {
        let k = u.int_in_range(0..=4)?;
        (0..k)
            .map(|_| {
                Ok(if u.ratio(1u8, 20)? {
                    u.arbitrary()?
                } else {
                    u.int_in_range(0..=n as u32 - 1)?
                })
            })
            .collect()
    };
    let field = |u: &mut Unstructured, s: &VecScene, around: bool| -> Result<Vec<[f32; 3]>> {
        let scale = common::any_f32(u)?;
        let base: Vec<[f32; 3]> = if around {
            s.positions().collect()
        } else {
            vec![[0.0; 3]; n]
        };
        let mut out = Vec::with_capacity(n);
        for b in base {
            let d = f32::from(u.arbitrary::<i8>()?) / 128.0;
            out.push([b[0] + scale * d, b[1], b[2] - scale * d]);
        }
        Ok(out)
    };
    while !u.is_empty() {
        let before = common::fingerprint(&s);
        let op = u.int_in_range(0u8..=17)?;
        // Err(true): refused, and documented to keep a changed state.
        let r: std::result::Result<(), bool> = match op {
            0..=3 => s.step().map(|_| ()).map_err(|_| false),
            4 | 5 => {
                let t = s.tool_target();
                let d = common::any3(u)?;
                s.step_haptic([t[0] + d[0], t[1] + d[1], t[2] + d[2]])
                    .map(|_| ())
                    .map_err(|_| false)
            }
            6 => {
                let i = u.int_in_range(0..=n as u32)?;
                s.set_force(i, common::any3(u)?).map_err(|_| false)
            }
            7 => s.fix_nodes(&ids(u)?).map_err(|_| false),
            8 => {
                s.unfix_all();
                s.clear_forces();
                Ok(())
            }
            9 => {
                let v = ids(u)?;
                let k = common::any_f32(u)?;
                s.grab(&v, k).map_err(|_| false)
            }
            10 => {
                s.release();
                Ok(())
            }
            11 => {
                let st = common::settings(u)?;
                s.set_settings(st).map_err(|_| false)
            }
            12 => match u.int_in_range(0u8..=2)? {
                0 => {
                    let i = u.int_in_range(0..=e)?;
                    s.set_young(i, common::any_f32(u)?).map_err(|_| false)
                }
                1 => s.set_young_all(common::any_f32(u)?).map_err(|_| false),
                _ => s.set_poisson(common::any_f32(u)?).map_err(|_| false),
            },
            13 => {
                let g = if u.arbitrary()? {
                    Some(common::plane(u)?)
                } else {
                    None
                };
                s.set_ground(g).map_err(|_| false)
            }
            14 => {
                let f = field(u, &s, true)?;
                s.set_positions(&f).map_err(|_| false)
            }
            15 => {
                let f = field(u, &s, false)?;
                if u.arbitrary()? {
                    s.set_velocities(&f).map_err(|_| false)
                } else {
                    s.set_displacements(&f).map_err(|_| false)
                }
            }
            16 => {
                s.reset_state();
                Ok(())
            }
            _ => {
                let cfg = StaticSettings {
                    max_iterations: u.int_in_range(0u32..=3)?,
                    cg_iterations: u.int_in_range(0u32..=60)?,
                    cg_tolerance: common::any_f32(u)?.abs(),
                    two_level: u.arbitrary()?,
                    ..StaticSettings::default()
                };
                match s.solve_static(&cfg, |st| {
                    assert!(st.residual.is_finite() && st.update.is_finite(), "{st:?}");
                }) {
                    Ok(_) => Ok(()),
                    Err(Error::StaticDiverged) => Err(true),
                    Err(_) => Err(false),
                }
            }
        };
        assert!(common::all_finite(&s), "op {op} left a non-finite state");
        if r == Err(false) {
            assert!(
                common::fingerprint(&s) == before,
                "the refused op {op} changed the scene"
            );
        }
    }
    Ok(())
}
