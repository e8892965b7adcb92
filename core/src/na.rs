//! nalgebra interop (feature `nalgebra`): positions, velocities, forces and
//! tool targets go in and out as `Point3<f32>` and `Vector3<f32>`, the types
//! rapier, bevy and parry users hold their data in.
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
        let mut a: StaticScene<20, { crate::element_blocks(24) }, 4> = StaticScene::new();
        let mut b: StaticScene<20, { crate::element_blocks(24) }, 4> = StaticScene::new();
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
}
