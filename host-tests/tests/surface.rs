//! Embedded surfaces on real meshes: a surface bound to the tetrahedra moves
//! exactly with any affine motion, keeps its shape under a rigid rotation,
//! binds consistently on shared faces and edges, gives the same bindings
//! whatever the vertex order, and refuses bad input with a typed error and
//! an unchanged scene.

use corofem::{
    surface_scratch_len, vertex_normals, BindStats, Error, Material, Parameter, SurfaceBinding,
    VecScene,
};
use corofem_host_tests::{box_mesh, f64v, shared_mesh, smooth_surface, CoreMesh, Rng};

const MATERIAL: Material = Material {
    young: 3.0e4,
    poisson: 0.45,
    density: 1000.0,
};

fn bind(scene: &VecScene, vertices: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<SurfaceBinding> {
    bind_with(scene, vertices, triangles, 0.5 * scene.mean_edge_length()).0
}

fn bind_with(
    scene: &VecScene,
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    reach: f32,
) -> (Vec<SurfaceBinding>, BindStats) {
    let mut scratch = vec![0; surface_scratch_len(vertices.len())];
    let mut b = vec![SurfaceBinding::EMPTY; vertices.len()];
    let stats = scene
        .bind_surface(vertices, triangles, reach, &mut scratch, &mut b)
        .expect("the surface binds");
    (b, stats)
}

fn update(scene: &VecScene, b: &[SurfaceBinding]) -> Vec<[f32; 3]> {
    let mut out = vec![[0.0; 3]; b.len()];
    scene.update_surface(b, &mut out).unwrap();
    out
}

/// Moves every node to `f(rest)`.
fn move_nodes(scene: &mut VecScene, mesh: &CoreMesh, f: impl Fn([f64; 3]) -> [f64; 3]) {
    let x: Vec<[f32; 3]> = mesh
        .nodes
        .iter()
        .map(|p| f(f64v::up(*p)).map(|c| c as f32))
        .collect();
    scene.set_positions(&x).unwrap();
}

fn max_abs(v: &[[f32; 3]]) -> f64 {
    v.iter()
        .flatten()
        .fold(0.0f64, |m, &c| m.max(f64::from(c).abs()))
}

/// The bound f32 vertex against the exact image of its rest position under an
/// affine map, for every vertex, within what f32 round-off allows: the
/// positions and displacements are rounded once each (`ε |x|`, `ε |u|`), the
/// weights once (`ε |w|`, and their sum is 1 to `ε Σ|wᵢ|`), and the update
/// adds four products to the rest position (four roundings of at most
/// `ε (|p| + Σ|wᵢ||uᵢ|)`). `16 ε Σ|wᵢ| (X + U)`, with `X` and `U` the largest
/// coordinate and displacement, covers these with room to spare.
fn assert_affine(mesh: &CoreMesh, surface: &corofem_io::Surface, a: [[f64; 3]; 3], t: [f64; 3]) {
    let mut scene = mesh.scene(&MATERIAL);
    let b = bind(&scene, &surface.vertices, &surface.triangles);
    let map = |p: [f64; 3]| {
        let q = f64v::rot(&a, p);
        [q[0] + t[0], q[1] + t[1], q[2] + t[2]]
    };
    move_nodes(&mut scene, mesh, map);
    let out = update(&scene, &b);
    let x = max_abs(&mesh.nodes);
    let u: Vec<[f32; 3]> = (0..mesh.nodes.len() as u32)
        .map(|i| scene.displacement(i).unwrap())
        .collect();
    let u = max_abs(&u);
    let mut worst = 0.0f64;
    for (bi, p) in b.iter().zip(&out) {
        let want = map(f64v::up(bi.rest_position()));
        let w: f64 = bi.weights().iter().map(|w| f64::from(*w).abs()).sum();
        let bound = 16.0 * f64::from(f32::EPSILON) * w * (x + u);
        let err = f64v::norm(f64v::sub(f64v::up(*p), want));
        assert!(err <= bound, "vertex off by {err:e} (bound {bound:e})");
        worst = worst.max(err / bound);
    }
    println!(
        "{} vertices: worst error {:.2} of the round-off bound",
        b.len(),
        worst
    );
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn an_affine_motion_moves_every_vertex_exactly() {
    for name in ["liver_ftw_3k.tetmesh", "bunny_ftw_3k.tetmesh"] {
        let mesh = shared_mesh(name);
        let surface = smooth_surface(&mesh, 2);
        let a = [[1.2, 0.3, -0.1], [0.05, 0.8, 0.2], [-0.2, 0.1, 1.1]];
        assert_affine(&mesh, &surface, a, [0.3, -1.5, 2.0]);
    }
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn a_rigid_rotation_keeps_the_surface_shape() {
    let mesh = shared_mesh("bunny_ftw_3k.tetmesh");
    let surface = smooth_surface(&mesh, 2);
    let mut scene = mesh.scene(&MATERIAL);
    let b = bind(&scene, &surface.vertices, &surface.triangles);
    let axis = [0.3, -0.5, 0.8];
    let n = f64v::norm(axis);
    let r = f64v::rotation(axis.map(|c| c / n), 2.1);
    move_nodes(&mut scene, &mesh, |p| {
        let q = f64v::rot(&r, p);
        [q[0] + 1.0, q[1], q[2] - 0.5]
    });
    let out = update(&scene, &b);
    // Every edge keeps its length and every normal turns with the body, to
    // f32 round-off of the coordinates (as in the affine test: `16 ε` of
    // the largest coordinate, twice for an edge).
    let x = max_abs(&mesh.nodes).max(max_abs(&out));
    let tol = 32.0 * f64::from(f32::EPSILON) * x;
    for t in &surface.triangles {
        for k in 0..3 {
            let (i, j) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let rest = f64v::norm(f64v::sub(
                f64v::up(surface.vertices[i]),
                f64v::up(surface.vertices[j]),
            ));
            let now = f64v::norm(f64v::sub(f64v::up(out[i]), f64v::up(out[j])));
            assert!((now - rest).abs() <= tol, "edge {i}-{j}: {rest} → {now}");
        }
    }
    let mut n0 = vec![[0.0; 3]; out.len()];
    let mut n1 = vec![[0.0; 3]; out.len()];
    vertex_normals(&surface.vertices, &surface.triangles, &mut n0).unwrap();
    vertex_normals(&out, &surface.triangles, &mut n1).unwrap();
    let mut worst = 0.0f64;
    for (a, b) in n0.iter().zip(&n1) {
        let turned = f64v::rot(&r, f64v::up(*a));
        worst = worst.max(f64v::norm(f64v::sub(turned, f64v::up(*b))));
    }
    // A unit normal from cross products of edges of relative error `tol / h`
    // (h ≥ 1 mm here): 1e-3 is that ratio with room.
    assert!(worst < 1e-3, "normals turned off by {worst}");
    println!("normals follow the rotation to {worst:e}");
}

#[test]
fn vertices_on_shared_faces_and_edges_move_with_the_face() {
    let mesh = box_mesh([1.0, 0.5, 0.5], [4, 2, 2], 6);
    let mut scene = mesh.scene(&MATERIAL);
    // The centroid of every face and the midpoint of every edge of every
    // tetrahedron: most are shared by two or more of them.
    let mut points = Vec::new();
    let mut on = Vec::new();
    for t in &mesh.tets {
        for f in [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]] {
            let n = f.map(|k| t[k]);
            let c = n.iter().fold([0.0f64; 3], |s, &i| {
                let p = f64v::up(mesh.nodes[i as usize]);
                [s[0] + p[0] / 3.0, s[1] + p[1] / 3.0, s[2] + p[2] / 3.0]
            });
            points.push(c.map(|x| x as f32));
            on.push(n.to_vec());
        }
        for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
            let (p, q) = (mesh.nodes[t[a] as usize], mesh.nodes[t[b] as usize]);
            points.push([0, 1, 2].map(|k| 0.5 * (p[k] + q[k])));
            on.push(vec![t[a], t[b]]);
        }
    }
    let b = bind(&scene, &points, &[]);
    // A non-affine motion: each node displaced at random.
    let mut rng = Rng::new(7);
    let u: Vec<[f32; 3]> = (0..mesh.nodes.len()).map(|_| rng.vec3(0.05)).collect();
    scene.set_displacements(&u).unwrap();
    let out = update(&scene, &b);
    for ((bi, p), nodes) in b.iter().zip(&out).zip(&on) {
        // The nodes off the face or edge weigh nothing (to the round-off of
        // the weights, relative to 1)…
        for (n, w) in bi.nodes().iter().zip(bi.weights()) {
            if !nodes.contains(n) {
                assert!(w.abs() < 1e-6, "node {n} off the face weighs {w}");
            }
        }
        // …so the vertex moves with the face's or edge's own interpolation,
        // whichever tetrahedron it is bound to.
        let k = nodes.len() as f64;
        let mean = nodes.iter().fold([0.0f64; 3], |s, &i| {
            let d = f64v::up(u[i as usize]);
            [s[0] + d[0] / k, s[1] + d[1] / k, s[2] + d[2] / k]
        });
        let want = [0, 1, 2].map(|c| f64::from(bi.rest_position()[c]) + mean[c]);
        // Round-off of positions of size 1 (ε) and of the weights' error
        // times displacements of 0.05: 1e-6 m is both with room.
        let err = f64v::norm(f64v::sub(f64v::up(*p), want));
        assert!(err < 1e-6, "vertex off its face's motion by {err:e}");
    }
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn bindings_do_not_depend_on_the_vertex_order() {
    let mesh = shared_mesh("liver_ftw_3k.tetmesh");
    let surface = smooth_surface(&mesh, 1);
    let scene = mesh.scene(&MATERIAL);
    let (b, stats) = bind_with(
        &scene,
        &surface.vertices,
        &[],
        0.5 * scene.mean_edge_length(),
    );
    assert!(stats.inside > 0 && stats.outside > 0, "{stats:?}");
    let n = surface.vertices.len();
    let perm: Vec<usize> = (0..n).map(|i| (i * 7919 + 13) % n).collect();
    // i ↦ (7919 i + 13) mod n is a permutation: 7919 is prime.
    assert!(n % 7919 != 0);
    let shuffled: Vec<[f32; 3]> = perm.iter().map(|&i| surface.vertices[i]).collect();
    let (b2, stats2) = bind_with(&scene, &shuffled, &[], 0.5 * scene.mean_edge_length());
    assert_eq!(stats.inside, stats2.inside);
    assert_eq!(stats.max_distance, stats2.max_distance);
    for (k, &i) in perm.iter().enumerate() {
        assert_eq!(b2[k], b[i], "vertex {i}");
    }
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn outside_vertices_extrapolate_from_the_nearest_tetrahedron() {
    let mesh = shared_mesh("liver_ftw_3k.tetmesh");
    let surface = smooth_surface(&mesh, 2);
    let scene = mesh.scene(&MATERIAL);
    let reach = 0.5 * scene.mean_edge_length();
    let (b, stats) = bind_with(&scene, &surface.vertices, &surface.triangles, reach);
    println!("{stats:?}, reach {reach}");
    assert!(stats.max_distance <= reach);
    // A vertex's distance to its tetrahedron is the reported one: the
    // tetrahedron's affine map gives back the rest position, and some
    // weight is negative exactly for the outside ones.
    // Below −1e-6: negative beyond the f32 rounding of weights of size 1.
    let outside = b
        .iter()
        .filter(|bi| bi.weights().iter().any(|&w| w < -1e-6))
        .count();
    assert!(outside > 0 && outside <= stats.outside as usize);
    // Refused with a reach below the farthest vertex's distance.
    let mut scratch = vec![0; surface_scratch_len(surface.vertices.len())];
    let mut b2 = vec![SurfaceBinding::EMPTY; surface.vertices.len()];
    let e = scene.bind_surface(
        &surface.vertices,
        &surface.triangles,
        0.9 * stats.max_distance,
        &mut scratch,
        &mut b2,
    );
    assert!(matches!(e, Err(Error::VertexTooFar { .. })), "{e:?}");
}

#[test]
fn bad_surfaces_are_refused_and_the_scene_is_unchanged() {
    let mesh = box_mesh([1.0, 0.5, 0.5], [4, 2, 2], 6);
    let scene = mesh.scene(&MATERIAL);
    let hash = scene.state_hash();
    let good = vec![
        [0.1f32, 0.1, 0.1],
        [0.5, 0.1, 0.1],
        [0.1, 0.4, 0.1],
        [0.3, 0.3, 0.3],
    ];
    let tris = vec![[0u32, 1, 2], [0, 1, 3]];
    let n = good.len();
    let run = |v: &[[f32; 3]], t: &[[u32; 3]], reach: f32, scratch: usize, slots: usize| {
        let mut s = vec![0; scratch];
        let mut b = vec![SurfaceBinding::EMPTY; slots];
        scene.bind_surface(v, t, reach, &mut s, &mut b).map(|_| ())
    };
    let full = surface_scratch_len(n);
    assert_eq!(run(&good, &tris, 0.1, full, n), Ok(()));
    let mut nan = good.clone();
    nan[2][1] = f32::NAN;
    assert_eq!(
        run(&nan, &tris, 0.1, full, n),
        Err(Error::NonFiniteVertex { vertex: 2 })
    );
    let mut far = good.clone();
    far[3] = [3.0, 0.0, 0.0];
    assert_eq!(
        run(&far, &tris, 0.1, full, n),
        Err(Error::VertexTooFar { vertex: 3 })
    );
    assert_eq!(
        run(&good, &[[0, 1, 2], [1, 1, 3]], 0.1, full, n),
        Err(Error::DegenerateTriangle { triangle: 1 })
    );
    assert_eq!(
        run(&good, &[[0, 1, 9]], 0.1, full, n),
        Err(Error::TriangleIndexOutOfRange {
            triangle: 0,
            vertex: 9
        })
    );
    assert_eq!(
        run(&good, &tris, 0.1, full, n - 1),
        Err(Error::TooManyVertices {
            count: n,
            capacity: n - 1
        })
    );
    for reach in [-1.0, f32::NAN, f32::INFINITY] {
        assert_eq!(
            run(&good, &tris, reach, full, n),
            Err(Error::InvalidParameter {
                parameter: Parameter::SurfaceReach
            })
        );
    }
    assert_eq!(
        run(&good, &tris, 0.1, full - 1, n),
        Err(Error::InvalidParameter {
            parameter: Parameter::SurfaceScratch
        })
    );
    let unbuilt = VecScene::with_capacity(10, 10);
    let mut s = vec![0; full];
    let mut b = vec![SurfaceBinding::EMPTY; n];
    assert_eq!(
        unbuilt.bind_surface(&good, &tris, 0.1, &mut s, &mut b),
        Err(Error::NotBuilt)
    );
    // The update refuses a wrong output length and bindings of a bigger
    // scene.
    let b = bind(&scene, &good, &tris);
    let mut out = vec![[0.0; 3]; n - 1];
    assert_eq!(
        scene.update_surface(&b, &mut out),
        Err(Error::InvalidParameter {
            parameter: Parameter::SurfaceOut
        })
    );
    let big = box_mesh([1.0, 1.0, 1.0], [8, 8, 8], 6);
    let big_scene = big.scene(&MATERIAL);
    let far_node = [[0.99f32, 0.99, 0.99]];
    let b_big = bind(&big_scene, &far_node, &[]);
    let mut out = [[0.0; 3]];
    assert!(matches!(
        scene.update_surface(&b_big, &mut out),
        Err(Error::NodeOutOfRange { .. })
    ));
    assert_eq!(scene.state_hash(), hash, "the scene is unchanged");
}
