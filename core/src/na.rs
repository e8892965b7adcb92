//! nalgebra interop (feature `nalgebra`): positions, velocities, forces and
//! tool targets go in and out as `Point3<f32>` and `Vector3<f32>`, and a
//! probe's pose as an `Isometry3<f32>`: the types rapier, bevy and parry
//! users hold their data in.
//!
//! Slices convert without a copy: a `Point3<f32>` and a `Vector3<f32>` are
//! three `f32` in a row, like the core's [`Vec3`](crate::Vec3) `[f32; 3]`,
//! and nalgebra says so through bytemuck's `Pod`, so the views are checked
//! casts with no unsafe code here:
//!
//! ```
//! use corofem::na::{arrays_as_points, points_as_arrays};
//! use nalgebra::Point3;
//!
//! let points = [Point3::new(0.0f32, 0.0, 0.0), Point3::new(1.0, 0.0, 0.0)];
//! let arrays: &[[f32; 3]] = points_as_arrays(&points);
//! assert_eq!(arrays[1], [1.0, 0.0, 0.0]);
//! assert!(core::ptr::eq(arrays_as_points(arrays), &points[..]));
//! ```
//!
//! The scene's methods that take slices (`build`, `set_positions`,
//! `set_velocities`) have `_points` and `_vectors` twins here that pass the
//! view on; single values convert with nalgebra's `From` (`Point3::from`,
//! `.into()`), which the `*_point` and `*_vector` getters do.
//!
//! A probe follows a tool's pose with [`Probe::move_to_isometry`](crate::Probe::move_to_isometry)
//! (feature `probe`): the pose's translation is the probe's centre and its
//! rotation turns the local z axis into the capsule's axis, so a capsule is
//! modelled along its local z (a sphere ignores the rotation), the axis
//! [`Probe::sphere`](crate::Probe::sphere) starts with. parry's
//! `Capsule::new_y` and rapier's `ColliderBuilder::capsule_y` lie along
//! their local y instead (their `_z` twins along z, as a probe): such a
//! collider's pose becomes a probe's with its rotation `r` replaced by
//! `r * q`, `q` the quarter turn about x that takes z to y (−90°, the
//! quaternion `(√½; −√½, 0, 0)`). [`Probe::pose_isometry`](crate::Probe::pose_isometry)
//! reads a pose back: the shortest arc from z to the axis, without the roll
//! about it, which a probe does not store. A haptic
//! device drives a [`Coupling`](crate::Coupling) with
//! [`Coupling::drive_point`](crate::Coupling::drive_point) (feature `coupling`).
//!
//! ```
//! # #[cfg(feature = "probe")]
//! # {
//! use corofem::Probe;
//! use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
//!
//! // A tool shaft 1 cm across, 4 cm long, turned 90° about x: along −y.
//! let mut shaft = Probe::capsule(0.005, 0.02, [0.0, 0.0, 0.1], [0.0, 0.0, 1.0]).unwrap();
//! let half = core::f32::consts::FRAC_1_SQRT_2; // cos 45° = sin 45°
//! let turn = UnitQuaternion::new_unchecked(Quaternion::new(half, half, 0.0, 0.0));
//! // (With nalgebra's `std` or `libm`: `Isometry3::new(translation, axis_angle)`.)
//! let pose = Isometry3 { rotation: turn, translation: Translation3::new(0.0, 0.0, 0.08) };
//! shaft.move_to_isometry(&pose).unwrap();
//! assert!((shaft.axis()[1] + 1.0).abs() < 1e-6);
//! // Read back: the same centre, and the quarter turn about x.
//! let back = shaft.pose_isometry();
//! assert_eq!(back.translation, pose.translation);
//! assert!((back.rotation.coords - turn.coords).amax() < 1e-6);
//! # }
//! ```

#[cfg(feature = "probe")]
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use nalgebra::{Point3, Vector3};

use crate::error::Error;
#[cfg(feature = "tool")]
use crate::error::StepError;
use crate::material::Material;
use crate::scene::{BuildOptions, Scene};
use crate::settings::StepStats;
use crate::storage::Storage;

/// Points viewed as `[f32; 3]` arrays, without a copy.
#[must_use]
pub fn points_as_arrays(points: &[Point3<f32>]) -> &[[f32; 3]] {
    bytemuck::cast_slice(points)
}

/// Arrays viewed as points, without a copy.
#[must_use]
pub fn arrays_as_points(arrays: &[[f32; 3]]) -> &[Point3<f32>] {
    bytemuck::cast_slice(arrays)
}

/// Arrays viewed as mutable points, without a copy: write a scene's
/// positions straight into a caller's `[Point3<f32>]` buffer through it.
#[must_use]
pub fn arrays_as_points_mut(arrays: &mut [[f32; 3]]) -> &mut [Point3<f32>] {
    bytemuck::cast_slice_mut(arrays)
}

/// Points viewed as mutable `[f32; 3]` arrays, without a copy.
#[must_use]
pub fn points_as_arrays_mut(points: &mut [Point3<f32>]) -> &mut [[f32; 3]] {
    bytemuck::cast_slice_mut(points)
}

/// Vectors viewed as `[f32; 3]` arrays, without a copy.
#[must_use]
pub fn vectors_as_arrays(vectors: &[Vector3<f32>]) -> &[[f32; 3]] {
    bytemuck::cast_slice(vectors)
}

/// Arrays viewed as vectors, without a copy.
#[must_use]
pub fn arrays_as_vectors(arrays: &[[f32; 3]]) -> &[Vector3<f32>] {
    bytemuck::cast_slice(arrays)
}

impl<S: Storage> Scene<S> {
    /// [`Scene::build`] from nalgebra points (no copy of the nodes).
    pub fn build_points(
        &mut self,
        nodes: &[Point3<f32>],
        tets: &[[u32; 4]],
        material: &Material,
        options: BuildOptions,
    ) -> Result<(), Error> {
        self.build(points_as_arrays(nodes), tets, material, options)
    }

    /// [`Scene::set_positions`] from nalgebra points (no copy).
    pub fn set_positions_points(&mut self, positions: &[Point3<f32>]) -> Result<(), Error> {
        self.set_positions(points_as_arrays(positions))
    }

    /// [`Scene::set_velocities`] from nalgebra vectors (no copy).
    pub fn set_velocities_vectors(&mut self, velocities: &[Vector3<f32>]) -> Result<(), Error> {
        self.set_velocities(vectors_as_arrays(velocities))
    }

    /// Current position of node `i` (m), as a point.
    #[must_use]
    pub fn position_point(&self, i: u32) -> Option<Point3<f32>> {
        self.position(i).map(Point3::from)
    }

    /// Rest position of node `i` (m), as a point.
    #[must_use]
    pub fn rest_position_point(&self, i: u32) -> Option<Point3<f32>> {
        self.rest_position(i).map(Point3::from)
    }

    /// Velocity of node `i` (m/s), as a vector.
    #[must_use]
    pub fn velocity_vector(&self, i: u32) -> Option<Vector3<f32>> {
        self.velocity(i).map(Vector3::from)
    }

    /// Current positions of all nodes, in order (m), as points.
    pub fn points(&self) -> impl Iterator<Item = Point3<f32>> + '_ {
        self.positions().map(Point3::from)
    }

    /// [`Scene::set_force`] with a nalgebra vector (N).
    #[cfg(feature = "loads")]
    pub fn set_force_vector(&mut self, i: u32, force: Vector3<f32>) -> Result<(), Error> {
        self.set_force(i, force.into())
    }

    /// [`Scene::set_tool_target`] at a nalgebra point (m).
    #[cfg(feature = "tool")]
    pub fn set_tool_target_point(&mut self, target: Point3<f32>) -> Result<(), Error> {
        self.set_tool_target(target.into())
    }

    /// [`Scene::step_haptic`] towards a nalgebra point (m).
    #[cfg(feature = "tool")]
    pub fn step_haptic_point(&mut self, target: Point3<f32>) -> Result<StepStats, StepError> {
        self.step_haptic(target.into())
    }
}

impl StepStats {
    /// [`StepStats::tool_force`] as a nalgebra vector (N).
    #[must_use]
    pub fn tool_force_vector(&self) -> Vector3<f32> {
        Vector3::from(self.tool_force)
    }

    /// [`StepStats::support_force`] as a nalgebra vector (N).
    #[must_use]
    pub fn support_force_vector(&self) -> Vector3<f32> {
        Vector3::from(self.support_force)
    }
}

/// The centre and axis of a probe posed by `pose`: its translation, and
/// its rotation applied to the local z axis. For the unit quaternion
/// `(w; x, y, z)` that is the rotation matrix's third column,
/// `(2 (x z + w y), 2 (y z − w x), 1 − 2 (x² + y²))`, written out: nalgebra's
/// quaternion product needs `f32: RealField`, which its `no_std` build
/// without `libm` does not give.
#[cfg(feature = "probe")]
fn centre_and_axis(pose: &Isometry3<f32>) -> ([f32; 3], [f32; 3]) {
    // nalgebra keeps a quaternion's coordinates as (i, j, k, w).
    let q = &pose.rotation.as_ref().coords;
    let (x, y, z, w) = (q.x, q.y, q.z, q.w);
    let axis = [
        2.0 * (x * z + w * y),
        2.0 * (y * z - w * x),
        1.0 - 2.0 * (x * x + y * y),
    ];
    (pose.translation.vector.into(), axis)
}

/// The shortest-arc rotation that turns the local z axis into the unit
/// `axis` `(a_x, a_y, a_z)`: about `z × axis`, by the angle θ between them.
/// Its quaternion is `(1 + a_z; −a_y, a_x, 0)` over its length
/// `√(2 (1 + a_z))`, i.e. `(cos θ/2; sin θ/2 · (z × axis)/|z × axis|)`.
/// Below the xy plane `1 + a_z` would cancel, so it is formed as
/// `(a_x² + a_y²) / (1 − a_z)`, the same for a unit axis, without the loss.
/// The axis opposite z has no shortest arc: it takes the half turn about x.
/// Written out, as `centre_and_axis`: `UnitQuaternion::rotation_between`
/// needs `f32: RealField`.
#[cfg(feature = "probe")]
fn rotation_from_z(axis: [f32; 3]) -> UnitQuaternion<f32> {
    let [x, y, z] = axis;
    let w = if z >= 0.0 {
        1.0 + z
    } else {
        (x * x + y * y) / (1.0 - z)
    };
    let n2 = w * w + x * x + y * y;
    // Opposite z (or too close for the squares to be normal numbers, less
    // than 1e-19 away): the half turn about x, which also turns z into −z.
    let q = if crate::math::regular(n2) {
        let r = 1.0 / crate::math::sqrt(n2);
        Quaternion::new(w * r, -y * r, x * r, 0.0)
    } else {
        Quaternion::new(0.0, 1.0, 0.0, 0.0)
    };
    UnitQuaternion::new_unchecked(q)
}

#[cfg(feature = "probe")]
impl crate::Probe {
    /// [`Probe::move_to`](crate::Probe::move_to) a tool's pose: the probe's
    /// centre at the pose's translation, a capsule's axis along the pose's
    /// rotation of the local z axis. Refused, with the probe unchanged, for
    /// a pose that is not finite.
    pub fn move_to_isometry(&mut self, pose: &Isometry3<f32>) -> Result<(), Error> {
        let (centre, axis) = centre_and_axis(pose);
        self.move_to(centre, axis)
    }

    /// [`Probe::place`](crate::Probe::place) at a pose, as
    /// [`Probe::move_to_isometry`](crate::Probe::move_to_isometry) reads it.
    pub fn place_isometry(&mut self, pose: &Isometry3<f32>) -> Result<(), Error> {
        let (centre, axis) = centre_and_axis(pose);
        self.place(centre, axis)
    }

    /// The probe's pose as an isometry, the inverse reading of
    /// [`Probe::move_to_isometry`](crate::Probe::move_to_isometry): the
    /// translation is the centre the next step ends at, the rotation the
    /// shortest arc that turns the local z axis into the probe's axis (for
    /// the axis opposite z, the half turn about x). A probe stores an axis,
    /// not a roll about it, so `move_to_isometry(&probe.pose_isometry())`
    /// keeps the centre and the axis, and a pose read back has no roll. A
    /// sphere's axis is the last one it was given (`[0, 0, 1]` from
    /// [`Probe::sphere`](crate::Probe::sphere)). The rotation is unit to the
    /// math backend's square root: to a few ulps with `libm`.
    #[must_use]
    pub fn pose_isometry(&self) -> Isometry3<f32> {
        Isometry3 {
            rotation: rotation_from_z(self.axis()),
            translation: Translation3::from(Vector3::from(self.position())),
        }
    }

    /// [`Probe::position`](crate::Probe::position) as a nalgebra point (m).
    #[must_use]
    pub fn position_point(&self) -> Point3<f32> {
        Point3::from(self.position())
    }

    /// [`Probe::axis`](crate::Probe::axis) as a nalgebra vector (unit).
    #[must_use]
    pub fn axis_vector(&self) -> Vector3<f32> {
        Vector3::from(self.axis())
    }

    /// [`Probe::force`](crate::Probe::force) as a nalgebra vector (N).
    #[must_use]
    pub fn force_vector(&self) -> Vector3<f32> {
        Vector3::from(self.force())
    }
}

#[cfg(feature = "coupling")]
impl crate::Coupling {
    /// [`Coupling::drive`](crate::Coupling::drive) from a device's position
    /// (m) and velocity (m/s) as nalgebra types; the force to render (N)
    /// comes back as a vector.
    pub fn drive_point(
        &mut self,
        probe: &mut crate::Probe,
        device: Point3<f32>,
        device_velocity: Vector3<f32>,
        dt: f32,
    ) -> Result<Vector3<f32>, Error> {
        self.drive(probe, device.into(), device_velocity.into(), dt)
            .map(Vector3::from)
    }

    /// [`Coupling::device_force`](crate::Coupling::device_force) as a
    /// nalgebra vector (N).
    #[must_use]
    pub fn device_force_vector(&self) -> Vector3<f32> {
        Vector3::from(self.device_force())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BoxMesh, StaticScene};

    #[test]
    fn views_share_the_memory_both_ways() {
        let mut arrays = [[1.0f32, 2.0, 3.0], [4.0, 5.0, 6.0]];
        let ptr = arrays.as_ptr().cast::<f32>();
        assert_eq!(arrays_as_points(&arrays)[1], Point3::new(4.0, 5.0, 6.0));
        assert_eq!(arrays_as_vectors(&arrays)[0], Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(arrays_as_points(&arrays).as_ptr().cast::<f32>(), ptr);
        arrays_as_points_mut(&mut arrays)[0].x = 7.0;
        assert_eq!(arrays[0][0], 7.0);
        let mut points = [Point3::new(0.0f32, 1.0, 2.0)];
        points_as_arrays_mut(&mut points)[0][2] = 9.0;
        assert_eq!(points[0].z, 9.0);
        let vectors = [Vector3::new(1.0f32, -1.0, 0.5)];
        assert_eq!(vectors_as_arrays(&vectors), &[[1.0, -1.0, 0.5]]);
        assert_eq!(
            vectors_as_arrays(&vectors).as_ptr().cast::<f32>(),
            vectors.as_ptr().cast::<f32>()
        );
    }

    /// A scene built and driven through the nalgebra methods has the bits of
    /// the same scene driven with arrays.
    #[test]
    fn scenes_through_nalgebra_match_scenes_through_arrays() {
        let mesh = BoxMesh {
            size: [0.2, 0.05, 0.05],
            cells: [4, 1, 1],
            tets_per_cell: 6,
        };
        let mut nodes = [[0.0f32; 3]; 20];
        let mut tets = [[0u32; 4]; 24];
        let (n, t) = mesh.generate(&mut nodes, &mut tets).unwrap();
        let material = Material {
            young: 1e5,
            poisson: 0.3,
            density: 1000.0,
        };
        let velocities: [[f32; 3]; 20] = core::array::from_fn(|i| [0.0, 0.01 * i as f32, 0.0]);
        crate::capacity! {
            /// Room for the box and a tool holding 4 nodes.
            struct Small { nodes: 20, elements: 24, grabs: 4 }
        }
        let mut a = StaticScene::<Small>::new();
        let mut b = StaticScene::<Small>::new();
        a.build(&nodes[..n], &tets[..t], &material, BuildOptions::default())
            .unwrap();
        b.build_points(
            arrays_as_points(&nodes[..n]),
            &tets[..t],
            &material,
            BuildOptions::default(),
        )
        .unwrap();
        a.set_velocities(&velocities[..n]).unwrap();
        b.set_velocities_vectors(arrays_as_vectors(&velocities[..n]))
            .unwrap();
        for _ in 0..5 {
            a.step().unwrap();
            b.step().unwrap();
        }
        assert_eq!(a.state_hash(), b.state_hash());
        for (i, p) in b.points().enumerate() {
            assert_eq!(Some(p), a.position_point(i as u32));
            assert_eq!(p, Point3::from(a.position(i as u32).unwrap()));
            assert_eq!(
                b.velocity_vector(i as u32),
                a.velocity(i as u32).map(Vector3::from)
            );
        }
        // Bad input through the twins is refused as through the originals.
        let mut bad = [Point3::origin(); 20];
        bad[3].x = f32::NAN;
        assert_eq!(
            b.set_positions_points(&bad[..n]),
            a.set_positions(points_as_arrays(&bad[..n]))
        );
        assert!(b.set_positions_points(&bad[..n]).is_err());
        assert_eq!(a.state_hash(), b.state_hash());
    }

    /// A pose moves a capsule as its centre and rotated z axis do; a pose
    /// that is not finite is refused and changes nothing.
    #[cfg(feature = "probe")]
    #[test]
    fn probes_follow_isometries() {
        use crate::Probe;
        use core::f32::consts::FRAC_1_SQRT_2 as HALF;
        use nalgebra::{Quaternion, Translation3, UnitQuaternion};
        let pose_of = |w: f32, x: f32, y: f32, z: f32| {
            // A struct literal: `Isometry3::from_parts` and `new` need
            // `f32: RealField`, which this no_std build lacks.
            Isometry3 {
                rotation: UnitQuaternion::new_unchecked(Quaternion::new(w, x, y, z)),
                translation: Translation3::new(0.01, 0.02, 0.03),
            }
        };
        let mut by_pose = Probe::capsule(0.01, 0.02, [0.0, 0.0, 0.1], [0.0, 0.0, 1.0]).unwrap();
        let mut by_arrays = by_pose;
        // 90° about x turns z into −y, −90° about x into +y (a y-capsule
        // collider's turn, in the module docs); 90° about y turns it into
        // +x; the identity keeps it. The quaternions' 1/√2 rounds in f32, so
        // the axes are exact to a few ulps of 1.
        for ((w, x, y, z), want) in [
            ((HALF, HALF, 0.0, 0.0), [0.0, -1.0, 0.0]),
            ((HALF, -HALF, 0.0, 0.0), [0.0, 1.0, 0.0]),
            ((HALF, 0.0, HALF, 0.0), [1.0, 0.0, 0.0]),
            ((1.0, 0.0, 0.0, 0.0), [0.0, 0.0, 1.0]),
        ] {
            let mut p = by_pose;
            p.move_to_isometry(&pose_of(w, x, y, z)).unwrap();
            for k in 0..3 {
                assert!((p.axis()[k] - want[k]).abs() < 1e-6, "{:?}", p.axis());
            }
        }
        let pose = pose_of(HALF, HALF, 0.0, 0.0);
        by_pose.move_to_isometry(&pose).unwrap();
        assert_eq!(by_pose.position_point(), Point3::new(0.01, 0.02, 0.03));
        // The same as the array method given the same centre and axis.
        by_arrays
            .move_to([0.01, 0.02, 0.03], by_pose.axis())
            .unwrap();
        assert_eq!(by_pose, by_arrays);
        assert_eq!(by_pose.axis_vector(), Vector3::from(by_pose.axis()));
        assert_eq!(by_pose.force_vector(), Vector3::from(by_pose.force()));
        // Placing takes the same reading, without the sweep.
        let mut placed = by_arrays;
        placed.place_isometry(&pose).unwrap();
        assert_eq!(placed.position(), by_pose.position());
        assert_eq!(placed.axis(), by_pose.axis());
        // Not finite: refused, the probe unchanged.
        let before = by_pose;
        let mut bad = pose;
        bad.translation.vector.x = f32::NAN;
        assert!(by_pose.move_to_isometry(&bad).is_err());
        assert!(by_pose.place_isometry(&bad).is_err());
        let mut bad = pose;
        bad.rotation = nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
            f32::INFINITY,
            0.0,
            0.0,
            0.0,
        ));
        assert!(by_pose.move_to_isometry(&bad).is_err());
        assert_eq!(by_pose, before);
        // A rotation of NaNs gives a NaN axis, which the array methods
        // refuse: whatever the translation, nothing changes.
        let mut bad = pose;
        bad.rotation = nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
            f32::NAN,
            f32::NAN,
            f32::NAN,
            f32::NAN,
        ));
        assert_eq!(
            by_pose.move_to_isometry(&bad),
            by_arrays.move_to([0.0; 3], [f32::NAN; 3])
        );
        assert!(by_pose.place_isometry(&bad).is_err());
        assert_eq!(by_pose, before);
    }

    /// A probe's pose reads back as the shortest arc from z to its axis,
    /// and moving a probe to the pose read back keeps its centre and axis,
    /// the axis opposite z and the axes near it included.
    #[cfg(feature = "probe")]
    #[test]
    fn probe_poses_read_back() {
        use crate::Probe;
        use core::f32::consts::FRAC_1_SQRT_2 as HALF;
        use nalgebra::{Quaternion, Translation3, UnitQuaternion};
        // Tolerance: the axis and the quaternion are unit vectors formed by
        // a few f32 products, one square root and one division, each off by
        // half an ulp of 1 (6e-8). The largest error below, 2.4e-7 (the
        // axis read back from [-3, 0.5, -2]), is 2 ulps; 1e-6 is 8, and
        // 1e-6 rad of angle, far below what a tool's pose carries.
        const TOL: f32 = 1e-6;
        let centre = [0.01, -0.02, 0.03];
        let mut probe = Probe::capsule(0.005, 0.02, centre, [0.0, 0.0, 1.0]).unwrap();
        // The sphere's and the fresh capsule's axis, z: the identity.
        let sphere = Probe::sphere(0.01, centre).unwrap();
        for p in [sphere, probe] {
            let pose = p.pose_isometry();
            assert_eq!(
                pose.rotation.into_inner(),
                Quaternion::new(1.0, 0.0, 0.0, 0.0)
            );
            assert_eq!(pose.translation.vector, Vector3::from(centre));
        }
        let tiny = 1e-10; // its square, 1e-20, vanishes next to 1
        for axis in [
            [0.0, -1.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 2.0, 3.0],
            [-3.0, 0.5, -2.0],
            [1e-3, 0.0, -1.0],
            [0.0, -1e-4, -1.0],
            [tiny, tiny, -1.0],
            [0.0, 0.0, -1.0],
        ] {
            probe.move_to(centre, axis).unwrap();
            let a = probe.axis();
            let pose = probe.pose_isometry();
            let q = pose.rotation.into_inner();
            // Unit, about an axis in the xy plane (⊥ z and ⊥ the axis: the
            // shortest arc), by the angle θ between z and the axis:
            // w = cos θ/2 ≥ 0, w² = (1 + a_z)/2.
            let n2 = q.w * q.w + q.i * q.i + q.j * q.j + q.k * q.k;
            assert!((n2 - 1.0).abs() < TOL, "{axis:?}: {q:?}");
            assert_eq!(q.k, 0.0);
            assert!(q.w >= 0.0);
            assert!(
                (q.w * q.w - 0.5 * (1.0 + a[2])).abs() < TOL,
                "{axis:?}: {q:?}"
            );
            assert!((q.i * a[0] + q.j * a[1]).abs() < TOL, "{axis:?}: {q:?}");
            // The round trip: the same centre, bit for bit, and the axis.
            let mut back = Probe::capsule(0.005, 0.02, [0.0; 3], [1.0, 0.0, 0.0]).unwrap();
            back.move_to_isometry(&pose).unwrap();
            assert_eq!(back.position(), centre);
            for k in 0..3 {
                assert!(
                    (back.axis()[k] - a[k]).abs() < TOL,
                    "{axis:?}: {:?}",
                    back.axis()
                );
            }
        }
        // Opposite z, exactly: the half turn about x.
        assert_eq!(
            probe.pose_isometry().rotation.into_inner(),
            Quaternion::new(0.0, 1.0, 0.0, 0.0)
        );
        // 90° about x turns z into −y, and the pose read back is that turn.
        let turn = UnitQuaternion::new_unchecked(Quaternion::new(HALF, HALF, 0.0, 0.0));
        let pose = Isometry3 {
            rotation: turn,
            translation: Translation3::new(0.0, 0.0, 0.08),
        };
        probe.move_to_isometry(&pose).unwrap();
        let back = probe.pose_isometry();
        assert_eq!(back.translation, pose.translation);
        assert!(
            (back.rotation.coords - turn.coords).amax() < TOL,
            "{back:?}"
        );
        // A roll about the local z (a quarter turn) is not stored: the pose
        // reads back without it, with the same centre and axis.
        let roll = UnitQuaternion::new_unchecked(Quaternion::new(HALF, 0.0, 0.0, HALF));
        probe
            .move_to_isometry(&Isometry3 {
                rotation: roll,
                translation: pose.translation,
            })
            .unwrap();
        assert_eq!(probe.axis(), [0.0, 0.0, 1.0]);
        let back = probe.pose_isometry();
        assert_eq!(
            back.rotation.into_inner(),
            Quaternion::new(1.0, 0.0, 0.0, 0.0)
        );
        assert_eq!(back.translation, pose.translation);
    }

    /// The coupling driven through nalgebra types gives the bits of the
    /// coupling driven with arrays.
    #[cfg(feature = "coupling")]
    #[test]
    fn couplings_through_nalgebra_match_couplings_through_arrays() {
        use crate::{Coupling, Probe};
        let mut a = Coupling::new(1000.0, 2.0, 0.01).unwrap();
        let mut b = a;
        let mut pa = Probe::sphere(0.01, [0.0, 0.0, 0.05]).unwrap();
        let mut pb = pa;
        for k in 0..10 {
            let x = [0.001 * k as f32, 0.0, 0.05 - 0.002 * k as f32];
            let v = [0.001, 0.0, -0.002];
            let fa = a.drive(&mut pa, x, v, 1e-3).unwrap();
            let fb = b
                .drive_point(&mut pb, Point3::from(x), Vector3::from(v), 1e-3)
                .unwrap();
            assert_eq!(Vector3::from(fa), fb);
        }
        assert_eq!(a, b);
        assert_eq!(pa, pb);
        assert_eq!(b.device_force_vector(), Vector3::from(a.device_force()));
        // Bad input is refused as through the arrays, changing nothing.
        let nan = Point3::new(f32::NAN, 0.0, 0.0);
        assert!(b.drive_point(&mut pb, nan, Vector3::zeros(), 1e-3).is_err());
        assert_eq!(a, b);
        assert_eq!(pa, pb);
    }
}
