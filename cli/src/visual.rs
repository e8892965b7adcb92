//! `[visual]`: a triangle surface carried by the tetrahedra. Read, scaled
//! like the mesh, bound to the built scene once, and moved with it at each
//! history record (and written beside the volume frames under `--vtk`).

use std::path::Path;

use corofem::{surface_scratch_len, vertex_normals, BindStats, SurfaceBinding, VecScene};
use corofem_io::VtkSeries;

use crate::error::{CliError, CliResult};
use crate::result::VisualResult;
use crate::scene_file::SceneSpec;

/// The default reach, in mean edge lengths of the tetrahedra: a surface
/// modelled over the same shape lies within a fraction of an element of
/// their hull, and one in other units or another place is refused.
pub const DEFAULT_REACH_EDGES: f32 = 0.5;

/// A bound surface and its buffers.
pub struct Visual {
    triangles: Vec<[u32; 3]>,
    bindings: Vec<SurfaceBinding>,
    stats: BindStats,
    reach: f32,
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    series: Option<VtkSeries>,
}

impl Visual {
    /// Reads the scene's `[visual]` surface and binds it to `scene` (built
    /// from the same scaled mesh).
    pub fn load(spec: &SceneSpec, scene: &VecScene) -> CliResult<Option<Visual>> {
        let Some(v) = &spec.visual else {
            return Ok(None);
        };
        let file = &spec.file;
        let at = |e: &dyn std::fmt::Display| {
            CliError(format!("{file}: [visual] file = {:?}: {e}", v.given))
        };
        let surface = corofem_io::read_surface(&v.path).map_err(|e| at(&e))?;
        let scale = spec.mesh.scale;
        let vertices: Vec<[f32; 3]> = surface
            .vertices
            .iter()
            .map(|p| p.map(|c| (f64::from(c) * scale) as f32))
            .collect();
        let reach = v
            .reach
            .unwrap_or(DEFAULT_REACH_EDGES * scene.mean_edge_length());
        let mut scratch = vec![0u32; surface_scratch_len(vertices.len())];
        let mut bindings = vec![SurfaceBinding::EMPTY; vertices.len()];
        let stats = scene
            .bind_surface(
                &vertices,
                &surface.triangles,
                reach,
                &mut scratch,
                &mut bindings,
            )
            .map_err(|e| match e {
                corofem::Error::VertexTooFar { vertex } => at(&format!(
                    "vertex {vertex} at {:?} lies farther than {reach} m from every \
                     tetrahedron (reach = {}); is the surface in the mesh's units \
                     and place? Raise `reach` in [visual] if it belongs there",
                    vertices[vertex as usize],
                    if v.reach.is_some() {
                        "as set".to_owned()
                    } else {
                        format!("{DEFAULT_REACH_EDGES} mean edge lengths")
                    }
                )),
                e => at(&e),
            })?;
        let n = vertices.len();
        Ok(Some(Visual {
            triangles: surface.triangles,
            bindings,
            stats,
            reach,
            positions: vertices,
            normals: vec![[0.0; 3]; n],
            series: None,
        }))
    }

    /// Writes the surface's frames into `dir` beside the volume's.
    pub fn start_vtk(&mut self, dir: &Path) -> CliResult<()> {
        let series = VtkSeries::create_surface(dir, &self.triangles)
            .map_err(|e| CliError(format!("--vtk: {e}")))?;
        self.series = Some(series);
        Ok(())
    }

    /// Moves the surface with the scene, and writes a frame at time `t` if
    /// `--vtk` asked for them.
    pub fn record(&mut self, scene: &VecScene, t: f64) -> CliResult<()> {
        self.update(scene)?;
        if let Some(series) = &mut self.series {
            vertex_normals(&self.positions, &self.triangles, &mut self.normals)
                .map_err(|e| CliError(format!("[visual]: {e}")))?;
            series
                .write_frame(t, &self.positions, &self.normals)
                .map_err(|e| CliError(format!("--vtk: {e}")))?;
        }
        Ok(())
    }

    fn update(&mut self, scene: &VecScene) -> CliResult<()> {
        scene
            .update_surface(&self.bindings, &mut self.positions)
            .map_err(|e| CliError(format!("[visual]: {e}")))
    }

    /// Frames written under `--vtk`.
    pub fn frames(&self) -> Option<usize> {
        self.series.as_ref().map(VtkSeries::frames)
    }

    /// A line for the run's summary.
    pub fn summary(&self) -> String {
        let s = &self.stats;
        format!(
            "{} vertices, {} triangles, {} outside the tetrahedra (at most {:.2e} m; reach {:.2e} m)",
            self.positions.len(),
            self.triangles.len(),
            s.outside,
            s.max_distance,
            self.reach
        )
    }

    /// The `visual` key of the result, at the scene's final state.
    pub fn finish(mut self, scene: &VecScene) -> CliResult<VisualResult> {
        self.update(scene)?;
        if let Some(series) = self.series.take() {
            series
                .finish()
                .map_err(|e| CliError(format!("--vtk: {e}")))?;
        }
        Ok(VisualResult {
            vertices: self.positions.len(),
            triangles: self.triangles.len(),
            inside: self.stats.inside,
            outside: self.stats.outside,
            max_distance: self.stats.max_distance,
            reach: self.reach,
            final_positions: self.positions,
        })
    }
}
