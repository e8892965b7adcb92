//! With enough iterations, one implicit step equals a dense direct solve of
//! the same linear system, assembled here independently in f64 with explicit
//! strain–displacement matrices `B` (not the solver's matrix-free H-form).

use corofem::{Material, Method, Settings};
use corofem_host_tests::{box_mesh, f64v, Rng};

type V = [f64; 3];

fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn unit(a: V) -> V {
    let n = f64v::norm(a);
    [a[0] / n, a[1] / n, a[2] / n]
}

/// QR frame rows and local coordinates [xb, xc, yc, xd, yd, zd]: `e1` along
/// `ab`, `e2` in the plane of `ab` and `ac`, `e3 = e1 × e2` (Nesme et al. 2005).
fn frame(ab: V, ac: V, ad: V) -> ([V; 3], [f64; 6]) {
    let e1 = unit(ab);
    let e3 = unit(f64v::cross(e1, ac));
    let e2 = f64v::cross(e3, e1);
    (
        [e1, e2, e3],
        [
            dot(e1, ab),
            dot(e1, ac),
            dot(e2, ac),
            dot(e1, ad),
            dot(e2, ad),
            dot(e3, ad),
        ],
    )
}

#[allow(clippy::needless_range_loop)] // index loops mirror the matrix formulas
/// Element stiffness (12×12, world) and elastic forces (12) of the QR method.
fn element(x0: [V; 4], x: [V; 4], lam: f64, mu: f64) -> (Vec<Vec<f64>>, Vec<f64>) {
    let (_, l0) = frame(sub(x0[1], x0[0]), sub(x0[2], x0[0]), sub(x0[3], x0[0]));
    let (e, l) = frame(sub(x[1], x[0]), sub(x[2], x[0]), sub(x[3], x[0]));
    let six_v0 = l0[0] * l0[2] * l0[5];
    let [xb, xc, yc, xd, yd, zd] = l;
    // Shape function gradients ×6V (rows: a, b, c, d) from the current shape,
    // derived here by inverting the local edge matrix rather than the table.
    let p = [[xb, 0.0, 0.0], [xc, yc, 0.0], [xd, yd, zd]];
    let det = xb * yc * zd;
    // Inverse of the matrix with rows p, times det: columns are the gradients.
    let inv = [
        [yc * zd, -(xc * zd), xc * yd - yc * xd],
        [0.0, xb * zd, -(xb * yd)],
        [0.0, 0.0, xb * yc],
    ];
    for i in 0..3 {
        for j in 0..3 {
            let v = dot(inv[i], p[j]);
            assert!((v - if i == j { det } else { 0.0 }).abs() < 1e-9 * det.abs().max(1.0));
        }
    }
    let g = [
        [
            -inv[0][0] - inv[1][0] - inv[2][0],
            -inv[0][1] - inv[1][1] - inv[2][1],
            -inv[0][2] - inv[1][2] - inv[2][2],
        ],
        inv[0],
        inv[1],
        inv[2],
    ];
    // B̃ (6×12), Voigt [xx, yy, zz, xy, yz, zx], engineering shear.
    let mut b = vec![vec![0.0; 12]; 6];
    for (n, [be, ga, de]) in g.iter().copied().enumerate() {
        let c = 3 * n;
        b[0][c] = be;
        b[1][c + 1] = ga;
        b[2][c + 2] = de;
        b[3][c] = ga;
        b[3][c + 1] = be;
        b[4][c + 1] = de;
        b[4][c + 2] = ga;
        b[5][c] = de;
        b[5][c + 2] = be;
    }
    let s = 1.0 / (36.0 * six_v0 / 6.0); // λ' = λ/(36 V₀)
    let mut d = vec![vec![0.0; 6]; 6];
    for i in 0..3 {
        for j in 0..3 {
            d[i][j] = lam * s;
        }
        d[i][i] += 2.0 * mu * s;
        d[i + 3][i + 3] = mu * s;
    }
    // Local K = B̃ᵀ D' B̃.
    let mut kl = vec![vec![0.0; 12]; 12];
    for i in 0..12 {
        for j in 0..12 {
            let mut v = 0.0;
            for r in 0..6 {
                for c in 0..6 {
                    v += b[r][i] * d[r][c] * b[c][j];
                }
            }
            kl[i][j] = v;
        }
    }
    // Local displacement u = local coordinates − rest ones.
    let ul = [
        0.0,
        0.0,
        0.0,
        l[0] - l0[0],
        0.0,
        0.0,
        l[1] - l0[1],
        l[2] - l0[2],
        0.0,
        l[3] - l0[3],
        l[4] - l0[4],
        l[5] - l0[5],
    ];
    let fl: Vec<f64> = (0..12)
        .map(|i| -(0..12).map(|j| kl[i][j] * ul[j]).sum::<f64>())
        .collect();
    // World: blocks Rᵀ (·) R with R rows e.
    let mut kw = vec![vec![0.0; 12]; 12];
    let mut fw = vec![0.0; 12];
    for bi in 0..4 {
        for r in 0..3 {
            fw[3 * bi + r] = (0..3).map(|k| e[k][r] * fl[3 * bi + k]).sum();
        }
        for bj in 0..4 {
            for r in 0..3 {
                for c in 0..3 {
                    let mut v = 0.0;
                    for k in 0..3 {
                        for m in 0..3 {
                            v += e[k][r] * kl[3 * bi + k][3 * bj + m] * e[m][c];
                        }
                    }
                    kw[3 * bi + r][3 * bj + c] = v;
                }
            }
        }
    }
    (kw, fw)
}

#[allow(clippy::needless_range_loop)] // index loops mirror the algorithm
/// Gaussian elimination with partial pivoting.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
            .unwrap();
        a.swap(k, p);
        b.swap(k, p);
        for i in k + 1..n {
            let f = a[i][k] / a[k][k];
            for j in k..n {
                a[i][j] -= f * a[k][j];
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = vec![0.0; n];
    for k in (0..n).rev() {
        x[k] = (b[k] - (k + 1..n).map(|j| a[k][j] * x[j]).sum::<f64>()) / a[k][k];
    }
    x
}

#[test]
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix formulas
fn converged_cg_step_equals_a_dense_direct_solve() {
    let mesh = box_mesh([2.0, 1.0, 1.0], [2, 1, 1], 6);
    let (young, nu, rho) = (2.0e7f64, 0.3f64, 1000.0f64);
    let (lam, mu) = (
        young * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        young / (2.0 * (1.0 + nu)),
    );
    let (h, am, ak, grav) = (0.01f64, 0.5f64, 0.01f64, [0.0, 0.0, -9.81]);
    let mut scene = mesh.scene(&Material {
        young: young as f32,
        poisson: nu as f32,
        density: rho as f32,
    });
    scene
        .set_settings(Settings {
            method: Method::Qr,
            dt: h as f32,
            cg_iterations: 1000,
            rayleigh_mass: am as f32,
            rayleigh_stiffness: ak as f32,
            gravity: [0.0, 0.0, -9.81],
            ..Settings::default()
        })
        .unwrap();
    let fixed = mesh.select(|p| p[0] == 0.0);
    scene.fix_nodes(&fixed).unwrap();
    // A random large deformation and random velocities (fixed nodes stay).
    let mut rng = Rng::new(11);
    let n = mesh.nodes.len();
    let x: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let p = mesh.nodes[i];
            if fixed.contains(&(i as u32)) {
                p
            } else {
                [
                    p[0] + rng.range(-0.15, 0.15) as f32,
                    p[1] + rng.range(-0.15, 0.15) as f32,
                    p[2] + rng.range(-0.15, 0.15) as f32,
                ]
            }
        })
        .collect();
    let v: Vec<[f32; 3]> = (0..n).map(|_| rng.vec3(0.5)).collect();
    scene.set_positions(&x).unwrap();
    scene.set_velocities(&v).unwrap();
    let v0: Vec<V> = scene.velocities().map(f64v::up).collect();

    // Assemble A and b in f64.
    let dof = 3 * n;
    let mut k = vec![vec![0.0; dof]; dof];
    let mut f = vec![0.0; dof];
    let mut mass = vec![0.0; n];
    for t in &mesh.tets {
        let idx = t.map(|i| i as usize);
        let x0 = idx.map(|i| f64v::up(mesh.nodes[i]));
        let xc = idx.map(|i| f64v::up(x[i]));
        let (ke, fe) = element(x0, xc, lam, mu);
        let vol = dot(
            f64v::cross(sub(x0[1], x0[0]), sub(x0[2], x0[0])),
            sub(x0[3], x0[0]),
        ) / 6.0;
        for a in 0..4 {
            mass[idx[a]] += rho * vol / 4.0;
            for r in 0..3 {
                f[3 * idx[a] + r] += fe[3 * a + r];
                for b in 0..4 {
                    for c in 0..3 {
                        k[3 * idx[a] + r][3 * idx[b] + c] += ke[3 * a + r][3 * b + c];
                    }
                }
            }
        }
    }
    let free: Vec<usize> = (0..dof)
        .filter(|d| !fixed.contains(&((d / 3) as u32)))
        .collect();
    let a: Vec<Vec<f64>> = free
        .iter()
        .map(|&i| {
            free.iter()
                .map(|&j| {
                    h * (ak + h) * k[i][j]
                        + if i == j {
                            (1.0 + h * am) * mass[i / 3]
                        } else {
                            0.0
                        }
                })
                .collect()
        })
        .collect();
    let b: Vec<f64> = free
        .iter()
        .map(|&i| {
            let kv: f64 = (0..dof).map(|j| k[i][j] * v0[j / 3][j % 3]).sum();
            h * (f[i] + mass[i / 3] * grav[i % 3] - am * mass[i / 3] * v0[i / 3][i % 3])
                - h * (ak + h) * kv
        })
        .collect();
    let dv_ref = solve(a, b);

    let stats = scene.step().unwrap();
    let mut worst = 0.0f64;
    let mut scale = 0.0f64;
    for (r, &i) in free.iter().enumerate() {
        let dv = scene.velocity((i / 3) as u32).unwrap()[i % 3] as f64 - v0[i / 3][i % 3];
        worst = worst.max((dv - dv_ref[r]).abs());
        scale = scale.max(dv_ref[r].abs());
    }
    eprintln!("CG: {} iterations, residual {:.1e}; largest |Δv − Δv_direct| = {worst:.2e} of max |Δv| = {scale:.3e}", stats.cg_iterations, stats.cg_residual);
    assert!(scale > 1e-3);
    // CG stops at its residual floor (ε relative); the f32 forces and the
    // f32 update v + Δv − v add a few ε of max|v| ≈ 0.5. Bound: 1e-4 relative.
    assert!(worst < 1e-4 * scale, "{worst} vs {scale}");
}
