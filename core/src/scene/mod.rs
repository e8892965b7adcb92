//! The scene: a validated mesh, its material and state, and the public API.

#[cfg(feature = "ground")]
mod ground;
mod settings;
#[cfg(feature = "tool")]
mod tool;

use crate::contact::Probes;
use crate::element::{block_and_lane, element_blocks, qr, Element, Method};
use crate::error::{Error, Parameter, StepError};
use crate::lanes::LANES;
use crate::material::{
    element_stiffness, lame, lame_per_young, validate_poisson, validate_young, Material,
};
use crate::math::{add, det3, is_finite3, sub, Vec3};
use crate::settings::{Preconditioner, Settings, StepStats};
use crate::state::{Header, IsaChoice, Lists, PreSlots, View};
use crate::storage::{
    ArrayStorage, Capacity, Node, NodeWork, PartsMut, Slots, Storage, FIXED, MAX_NODES,
};
#[cfg(feature = "tool")]
use crate::tool::ToolState;
use crate::InstructionSet;

/// Options of [`Scene::build`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BuildOptions {
    /// Swap the last two nodes of negatively oriented tetrahedra instead of
    /// rejecting them. Default off.
    pub reorient: bool,
}

/// A soft body: tetrahedral mesh, material, state, constraints and loads.
///
/// Generic over where its data lives: [`StaticScene`] keeps everything in
/// arrays of fixed capacity (a `static` on a microcontroller), `VecScene`
/// in `Vec`s sized at run time (feature `alloc`), and
/// [`Scene::with_storage`] takes any other [`Storage`] (caller-owned slices).
///
/// # Node indices
///
/// A node is named by a `u32` everywhere: in the tetrahedra given to
/// [`Scene::build`], in node lists ([`Scene::fix_nodes`], `Scene::grab`), in
/// per-node getters and setters ([`Scene::position`], `Scene::set_force`),
/// in [`Scene::element_nodes`] and in errors. `u32` because it is the width
/// of mesh files and of the C API, and the same on every target (a `usize`
/// is not), so an index read from a file reaches the scene unchanged and an
/// out-of-range one is reported, not truncated. The elements keep `u16`
/// indices inside (at most 65 536 nodes, [`Scene::node_capacity`]); that is a
/// storage detail. Counts, and elements, which are positions in the
/// caller's slice of tetrahedra, are `usize`.
///
/// ```
/// use corofem::{BuildOptions, Material, StaticScene};
/// let nodes = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let tets = [[0, 1, 2, 3]];
/// // Capacity: 4 nodes and one tetrahedron.
/// corofem::capacity! { struct Tet { nodes: 4, elements: 1 } }
/// let mut scene = StaticScene::<Tet>::new();
/// scene.build(&nodes, &tets, &Material::default(), BuildOptions::default()).unwrap();
/// scene.fix_nodes(&[0, 1, 2]).unwrap();
/// let stats = scene.step().unwrap();
/// assert_eq!(stats.inverted, 0);
/// assert!(scene.position(3).unwrap()[2] < 1.0); // it sags under gravity
/// ```
#[derive(Clone, Debug)]
pub struct Scene<S: Storage> {
    pub(crate) hdr: Header,
    pub(crate) store: S,
}

/// A scene in fixed-capacity arrays ([`ArrayStorage`]), as the [`Capacity`]
/// `C` declares them: with [`capacity!`](crate::capacity), e.g.
/// `corofem::capacity! { struct Beam { nodes: 99, elements: 240, grabs: 3 } }`
/// and `StaticScene<Beam>`. [`StaticScene::new`](Scene::new) is a `const fn`
/// whose value is all zero bits, for a `static` in `.bss`.
pub type StaticScene<C> = Scene<ArrayStorage<C>>;

impl<C: Capacity> Scene<ArrayStorage<C>> {
    /// An empty scene, in `const` context.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            hdr: Header::EMPTY,
            store: ArrayStorage::new(),
        }
    }
}

impl<C: Capacity> Default for Scene<ArrayStorage<C>> {
    fn default() -> Self {
        Self::new()
    }
}

/// A scene in `Vec`s sized at run time (feature `alloc`), for host programs
/// whose meshes are known only when they run: every node can be grabbed or
/// loaded.
#[cfg(feature = "alloc")]
pub type VecScene = Scene<crate::storage::VecStorage>;

#[cfg(feature = "alloc")]
impl Scene<crate::storage::VecStorage> {
    /// An empty scene with room for exactly `nodes` nodes and `elements`
    /// tetrahedra: [`VecStorage::with_capacity`](crate::VecStorage::with_capacity).
    #[must_use]
    pub fn with_capacity(nodes: usize, elements: usize) -> Self {
        Self::with_storage(crate::storage::VecStorage::with_capacity(nodes, elements))
    }
}

impl<S: Storage> Scene<S> {
    /// An empty scene over `store`.
    pub const fn with_storage(store: S) -> Self {
        Self {
            hdr: Header::EMPTY,
            store,
        }
    }

    /// What the storage holds: [`Storage::capacity`].
    #[must_use]
    pub fn capacity(&self) -> Slots {
        self.store.capacity()
    }

    /// Node capacity of the storage (at most 65 536 are usable):
    /// `capacity().nodes`.
    #[must_use]
    pub fn node_capacity(&self) -> usize {
        self.capacity().nodes
    }

    /// Element capacity of the storage (blocks × elements per block):
    /// `capacity().elements`.
    #[must_use]
    pub fn element_capacity(&self) -> usize {
        self.capacity().elements
    }

    crate::backend::isa_inline!(
        pub(crate) fn view(&mut self) -> View<'_> {
            if !self.hdr.settings_valid {
                let defaults = self.default_settings();
                self.hdr.write_default_settings(defaults);
            }
            let (n, e) = (self.hdr.n_nodes, self.hdr.n_elems);
            #[cfg(feature = "tool")]
            let n_grabs = self.hdr.tool.count as usize;
            #[cfg(feature = "loads")]
            let n_loads = self.hdr.n_loads;
            let p = self.store.parts_mut();
            View {
                hdr: &mut self.hdr,
                nodes: p.nodes.get_mut(..n).unwrap_or_default(),
                work: p.work.get_mut(..n).unwrap_or_default(),
                elems: p.elems.get_mut(..element_blocks(e)).unwrap_or_default(),
                n_elems: e,
                lists: Lists {
                    #[cfg(feature = "tool")]
                    grabs: p.grabs.get(..n_grabs).unwrap_or_default(),
                    #[cfg(feature = "loads")]
                    loads: p.loads.get(..n_loads).unwrap_or_default(),
                    _life: core::marker::PhantomData,
                },
                pre: PreSlots {
                    #[cfg(feature = "two-level")]
                    parts: crate::slots::Parts {
                        blocks: p.blocks.get_mut(..n).unwrap_or_default(),
                        aggs: p.aggs,
                        coarse: p.coarse,
                    },
                    _life: core::marker::PhantomData,
                },
                probes: Probes {
                    #[cfg(feature = "probe")]
                    list: &mut [],
                    _life: core::marker::PhantomData,
                },
            }
        }
    );

    /// Whether this build and the storage can run `pre` (for a scene of as
    /// many nodes as the storage holds): `pre` is at most
    /// `capacity().preconditioner`, in the order `Mass`, `BlockJacobi`,
    /// `TwoLevel`.
    #[must_use]
    pub fn supports(&self, pre: Preconditioner) -> bool {
        pre as u8 <= self.capacity().preconditioner as u8
    }

    /// Node `i`, if the scene has it.
    fn node(&self, i: u32) -> Option<&Node> {
        self.nodes().get(i as usize)
    }

    pub(crate) fn nodes(&self) -> &[Node] {
        self.store
            .parts()
            .nodes
            .get(..self.hdr.n_nodes)
            .unwrap_or_default()
    }

    /// Element `e`, if the scene has it.
    pub(crate) fn element(&self, e: usize) -> Option<Element> {
        if e >= self.hdr.n_elems {
            return None;
        }
        let (b, j) = block_and_lane(e, self.hdr.n_elems);
        self.store.parts().elems.get(b).map(|blk| blk.get(j))
    }

    /// Builds the scene from node positions (m) and tetrahedra (node indices),
    /// replacing what was there. Everything is validated before anything is
    /// written: on error the scene is unchanged.
    ///
    /// Rest local frames are computed with the step's own kernel, so the rest
    /// shape is an exact equilibrium in f32. Masses are lumped: each node gets
    /// a quarter of `ρ V₀` of every element around it. Settings are kept;
    /// fixed nodes, forces, the tool and the velocities are reset.
    pub fn build(
        &mut self,
        positions: &[Vec3],
        tets: &[[u32; 4]],
        material: &Material,
        options: BuildOptions,
    ) -> Result<(), Error> {
        material.validate()?;
        let node_cap = self.node_capacity();
        let elem_cap = self.element_capacity();
        if positions.len() > node_cap {
            return Err(Error::TooManyNodes {
                count: positions.len(),
                capacity: node_cap,
            });
        }
        if tets.len() > elem_cap {
            return Err(Error::TooManyElements {
                count: tets.len(),
                capacity: elem_cap,
            });
        }
        if tets.is_empty() {
            return Err(Error::NoElements);
        }
        // `as u32`: below the node capacity (at most `MAX_NODES`), checked above.
        if let Some(node) = positions.iter().position(|p| !is_finite3(*p)) {
            return Err(Error::NonFiniteCoordinate { node: node as u32 });
        }
        let per_young = lame_per_young(material.poisson);
        let PartsMut {
            nodes, work, elems, ..
        } = self.store.parts_mut();
        // Pass 1: validate every element; mark used nodes in the solver
        // scratch (`inv_p`, which every step recomputes before it reads it:
        // nothing observable changes on error).
        for w in work.iter_mut() {
            w.inv_p = 0.0;
        }
        for (e, tet) in tets.iter().enumerate() {
            let t = oriented(e, tet, positions, options)?;
            let (frame, six_v0) = rest_frame(positions, &t);
            // The 6V-scaled shape-function gradients are products of two
            // local coordinates, and their world versions sums of three such
            // products: they must not overflow (an edge of 1e20 m next to one
            // of 1e19 m; or 1e38 m next to a sliver, found by fuzzing), or
            // the rest state is not even an equilibrium (0 · ∞). Check them
            // as the step will compute them: with the step's own kernel.
            let coefs = lame(element_stiffness(material.young, six_v0), per_young);
            let gradients_finite = rest_gradients(positions, &t, &frame, coefs)
                .iter()
                .flatten()
                .all(|g| g.is_finite());
            // Everything the element contributes must be a normal f32 number:
            // its frame (no fallback for an edge whose square over- or
            // underflows), 1/(36 V₀), its share ρ V₀/4 of the lumped mass (a
            // subnormal mass makes the preconditioner 1/m infinite) and its
            // Lamé coefficients E/(36 V₀).
            let quarter = material.density * six_v0 * (1.0 / 24.0);
            if !(regular_frame(positions, &t)
                && gradients_finite
                && six_v0 >= f32::MIN_POSITIVE
                && six_v0.is_finite()
                && (1.0 / (6.0 * six_v0)).is_finite()
                && quarter >= f32::MIN_POSITIVE
                && quarter.is_finite()
                && coefs[0].is_finite()
                && coefs[1].is_finite())
            {
                return Err(Error::DegenerateElement { element: e });
            }
            for i in t {
                if let Some(w) = work.get_mut(i as usize) {
                    w.inv_p = 1.0;
                }
            }
        }
        if let Some(node) = work
            .iter()
            .take(positions.len())
            .position(|w| w.inv_p == 0.0)
        {
            return Err(Error::UnusedNode { node: node as u32 });
        }
        // Pass 2: write.
        for (slot, p) in nodes.iter_mut().zip(positions) {
            *slot = Node {
                x0: *p,
                ..Node::EMPTY
            };
        }
        for w in work.iter_mut() {
            *w = NodeWork::EMPTY;
        }
        for (e, tet) in tets.iter().enumerate() {
            let (b, j) = block_and_lane(e, tets.len());
            let Some(block) = elems.get_mut(b) else {
                break; // capacity checked above
            };
            // Validated above: `oriented` cannot fail here.
            let t = oriented(e, tet, positions, options).unwrap_or([0; 4]);
            let (frame, six_v0) = rest_frame(positions, &t);
            let stiffness = element_stiffness(material.young, six_v0);
            let grad = rest_gradients(positions, &t, &frame, lame(stiffness, per_young));
            let el = Element {
                nodes: [t[0] as u16, t[1] as u16, t[2] as u16, t[3] as u16],
                rest: frame.local,
                stiffness,
                grad,
                #[cfg(any(feature = "polar", feature = "linear"))]
                rest_grad: grad,
                #[cfg(feature = "polar")]
                rot: crate::element::rotation::IDENTITY,
            };
            block.set(j, &el);
            let quarter = material.density * six_v0 * (1.0 / 24.0);
            for i in t {
                if let Some(n) = nodes.get_mut(i as usize) {
                    n.mass += quarter;
                }
            }
        }
        #[cfg(feature = "probe")]
        mark_boundary(nodes, work, tets, positions, options);
        self.hdr.n_nodes = positions.len();
        self.hdr.n_elems = tets.len();
        self.hdr.poisson = material.poisson;
        self.hdr.density = material.density;
        self.hdr.time = 0.0;
        self.hdr.inverted = 0;
        self.hdr.any_fixed = false;
        self.hdr.invalidate_coarse();
        self.hdr.placed();
        #[cfg(feature = "tool")]
        {
            self.hdr.tool = ToolState::NONE;
        }
        #[cfg(feature = "loads")]
        {
            self.hdr.n_loads = 0;
        }
        Ok(())
    }

    /// Number of nodes of the built scene.
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.hdr.n_nodes
    }

    /// Number of tetrahedra of the built scene.
    #[must_use]
    pub fn element_count(&self) -> usize {
        self.hdr.n_elems
    }

    /// The step settings ([`Scene::default_settings`] until set).
    #[must_use]
    pub fn settings(&self) -> &Settings {
        if self.hdr.settings_valid {
            &self.hdr.settings
        } else {
            self.defaults()
        }
    }

    /// The default settings this build and this scene's storage run:
    /// [`Settings::new`] made [`Settings::compiled`], with the lumped mass
    /// (the paper's CG, [`Settings::with_preconditioner`]) where the storage
    /// holds no two-level preconditioner's slots (a [`StaticScene`] whose
    /// capacity leaves out `preconditioner`; a [`VecScene`] and storage made
    /// with them have them). What the scene steps
    /// with until [`Scene::set_settings`]; start custom settings from it
    /// (`Settings { dt, ..scene.default_settings() }`) to keep what the
    /// build and the storage can run.
    #[must_use]
    pub fn default_settings(&self) -> Settings {
        *self.defaults()
    }

    fn defaults(&self) -> &'static Settings {
        const DEFAULTS: Settings = Settings::new().compiled();
        const MASS: Settings = Settings::with_preconditioner(Preconditioner::Mass).compiled();
        if self.supports(DEFAULTS.preconditioner) {
            &DEFAULTS
        } else {
            &MASS
        }
    }

    /// Replaces the step settings after validating them. Switching to the
    /// polar method restarts its rotations from the identity.
    pub fn set_settings(&mut self, settings: Settings) -> Result<(), Error> {
        settings.validate()?;
        if !self.supports(settings.preconditioner) {
            return Err(Error::PreconditionerUnavailable {
                preconditioner: settings.preconditioner,
            });
        }
        // The coarse factor depends on the system matrix's coefficients
        // (`Header::coefficients`: dt, damping) and on the preconditioner;
        // gravity, the budget or the warm start leave it valid.
        let before = self.hdr.coefficients();
        if settings.preconditioner != self.settings().preconditioner {
            self.hdr.invalidate_coarse();
        }
        #[cfg(feature = "polar")]
        if settings.method == Method::Polar && self.settings().method != Method::Polar {
            for block in self.view().elems.iter_mut() {
                block.rot = crate::element::ElementBlock::POLAR_START;
            }
        }
        self.hdr.settings = settings;
        self.hdr.settings_valid = true;
        self.hdr.coefficients_changed(before);
        self.hdr.forget_energy();
        Ok(())
    }

    /// Changes only the element method.
    pub fn set_method(&mut self, method: Method) -> Result<(), Error> {
        self.set_settings(Settings {
            method,
            ..*self.settings()
        })
    }

    /// Simulated time since the build (s).
    #[must_use]
    pub fn time(&self) -> f64 {
        self.hdr.time
    }

    /// Current position of node `i` (m).
    #[must_use]
    pub fn position(&self, i: u32) -> Option<Vec3> {
        self.node(i).map(Node::position)
    }

    /// Rest position of node `i` (m).
    #[must_use]
    pub fn rest_position(&self, i: u32) -> Option<Vec3> {
        self.node(i).map(|n| n.x0)
    }

    /// Displacement of node `i` from rest (m).
    #[must_use]
    pub fn displacement(&self, i: u32) -> Option<Vec3> {
        self.node(i).map(|n| n.u)
    }

    /// Velocity of node `i` (m/s).
    #[must_use]
    pub fn velocity(&self, i: u32) -> Option<Vec3> {
        self.node(i).map(|n| n.v)
    }

    /// Lumped mass of node `i` (kg).
    #[must_use]
    pub fn mass(&self, i: u32) -> Option<f32> {
        self.node(i).map(|n| n.mass)
    }

    /// Whether node `i` is fixed.
    #[must_use]
    pub fn is_fixed(&self, i: u32) -> bool {
        self.node(i).is_some_and(|n| n.flags & FIXED != 0)
    }

    /// Whether node `i` is on the mesh's boundary (in a face of only one
    /// tetrahedron): the nodes that probes touch. Found at `build`.
    #[cfg(feature = "probe")]
    #[must_use]
    pub fn on_boundary(&self, i: u32) -> bool {
        self.node(i)
            .is_some_and(|n| n.flags & crate::storage::BOUNDARY != 0)
    }

    /// Current positions of all nodes, in order (m).
    pub fn positions(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.nodes().iter().map(Node::position)
    }

    /// Velocities of all nodes, in order (m/s).
    pub fn velocities(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.nodes().iter().map(|n| n.v)
    }

    /// Node indices of element `e` (as stored: re-oriented if asked).
    #[must_use]
    pub fn element_nodes(&self, e: usize) -> Option<[u32; 4]> {
        self.element(e).map(|el| el.nodes.map(u32::from))
    }

    /// Young's modulus of element `e` (Pa). An element keeps `E / (36 V₀)`,
    /// so this is that times `36 V₀`: the value set, to within f32 round-off
    /// (a few units in the last place) while `E / (36 V₀)` is a normal f32
    /// number; at the ends of the f32 range it can come back as 0 or
    /// infinity.
    #[must_use]
    pub fn young(&self, e: usize) -> Option<f32> {
        self.element(e).map(|el| el.stiffness * (6.0 * el.six_v0()))
    }

    /// Mean length of the tetrahedra's edges at rest (m), each edge counted
    /// once per tetrahedron it belongs to; 0 before a build. A length scale
    /// for what depends on the element size: a picking radius, the `reach`
    /// of an embedded surface.
    #[must_use]
    pub fn mean_edge_length(&self) -> f32 {
        let nodes = self.nodes();
        let x0 = |i: u16| nodes.get(usize::from(i)).map_or([0.0; 3], |n| n.x0);
        let mut sum = 0.0f64;
        for e in 0..self.hdr.n_elems {
            let Some(el) = self.element(e) else { break };
            for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
                let d = crate::math::sub(x0(el.nodes[b]), x0(el.nodes[a]));
                sum += f64::from(crate::math::sqrt(crate::math::dot(d, d)));
            }
        }
        (sum / (6 * self.hdr.n_elems).max(1) as f64) as f32
    }

    /// Rest volume of element `e` (m³).
    #[must_use]
    pub fn rest_volume(&self, e: usize) -> Option<f32> {
        self.element(e).map(|el| el.six_v0() * (1.0 / 6.0))
    }

    /// Elements with negative volume at the start of the last step.
    #[must_use]
    pub fn inverted_count(&self) -> u32 {
        self.hdr.inverted
    }

    /// Sets Young's modulus of one element (Pa, `≥ 0`). Refused as `young`
    /// when the element's `λ/(36 V₀)` or `μ/(36 V₀)` would overflow f32.
    pub fn set_young(&mut self, e: usize, young: f32) -> Result<(), Error> {
        validate_young(young)?;
        let per_young = self.hdr.per_young();
        let el = self
            .element(e)
            .ok_or(Error::ElementOutOfRange { element: e })?;
        let stiffness = element_stiffness(young, el.six_v0());
        if !lame_finite(stiffness, per_young) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::Young,
            });
        }
        let (b, j) = block_and_lane(e, self.hdr.n_elems);
        if let Some(block) = self.view().elems.get_mut(b) {
            block.set_stiffness(j, stiffness);
        }
        self.hdr.invalidate_coarse();
        self.hdr.forget_energy();
        Ok(())
    }

    /// Sets Young's modulus of every element (Pa, `≥ 0`) — the paper's rabbit:
    /// crushed at zero stiffness, then raised. Refused as `young` when an
    /// element's `λ/(36 V₀)` or `μ/(36 V₀)` would overflow f32.
    pub fn set_young_all(&mut self, young: f32) -> Result<(), Error> {
        validate_young(young)?;
        if !self.lame_fits(Some(young), self.hdr.poisson) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::Young,
            });
        }
        self.write_young_all(young);
        self.hdr.forget_energy();
        Ok(())
    }

    /// Writes Young's modulus `young` (Pa, checked) into every element.
    fn write_young_all(&mut self, young: f32) {
        self.hdr.invalidate_coarse();
        let v = self.view();
        // Every slot, in storage order (which element is where is no matter).
        for s in 0..v.n_elems {
            if let Some(block) = v.elems.get_mut(s / LANES) {
                let six_v0 = block.get(s % LANES).six_v0();
                block.set_stiffness(s % LANES, element_stiffness(young, six_v0));
            }
        }
    }

    /// Sets the Poisson ratio of the whole body (`0 ≤ ν < 0.5`). Refused as
    /// `poisson` when an element's `λ/(36 V₀)` would overflow f32.
    pub fn set_poisson(&mut self, poisson: f32) -> Result<(), Error> {
        validate_poisson(poisson)?;
        if !self.lame_fits(None, poisson) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::Poisson,
            });
        }
        self.hdr.poisson = poisson;
        self.hdr.invalidate_coarse();
        self.hdr.forget_energy();
        Ok(())
    }

    /// Sets Young's modulus of every element (Pa, `≥ 0`) and the Poisson
    /// ratio (`0 ≤ ν < 0.5`) together: checked as a pair, so a pair that fits
    /// is taken whatever the order, and on error nothing changes. Refused as
    /// `young` when an element's `λ/(36 V₀)` or `μ/(36 V₀)` would overflow.
    pub fn set_elasticity(&mut self, young: f32, poisson: f32) -> Result<(), Error> {
        validate_young(young)?;
        validate_poisson(poisson)?;
        if !self.lame_fits(Some(young), poisson) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::Young,
            });
        }
        self.hdr.poisson = poisson;
        self.write_young_all(young);
        self.hdr.forget_energy();
        Ok(())
    }

    /// Whether every element's coefficients are finite with Young's modulus
    /// `young` (or each element's own) and Poisson ratio `poisson`.
    fn lame_fits(&self, young: Option<f32>, poisson: f32) -> bool {
        let per_young = lame_per_young(poisson);
        (0..self.hdr.n_elems).all(|e| {
            self.element(e).is_none_or(|el| {
                let stiffness = young.map_or(el.stiffness, |y| element_stiffness(y, el.six_v0()));
                lame_finite(stiffness, per_young)
            })
        })
    }

    /// Fixes the listed nodes (they stop and stay where they are).
    pub fn fix_nodes(&mut self, nodes: &[u32]) -> Result<(), Error> {
        let v = self.view();
        check_nodes(nodes, v.nodes.len())?;
        for &i in nodes {
            if let Some(n) = v.nodes.get_mut(i as usize) {
                n.flags |= FIXED;
                v.hdr.any_fixed = true;
                n.v = [0.0; 3];
            }
        }
        v.hdr.invalidate_coarse();
        self.hdr.forget_energy();
        Ok(())
    }

    /// Frees every fixed node.
    pub fn unfix_all(&mut self) {
        self.hdr.forget_energy();
        self.hdr.placed();
        let v = self.view();
        for n in v.nodes.iter_mut() {
            n.flags &= !FIXED;
        }
        v.hdr.any_fixed = false;
        v.hdr.invalidate_coarse();
    }

    /// Sets the constant external force on node `i` (N); a zero force removes
    /// it and frees its slot. Refused, with nothing changed, for a node out of
    /// range, a non-finite force, or a new loaded node when every load slot
    /// is taken ([`Error::TooManyLoads`]).
    #[cfg(feature = "loads")]
    pub fn set_force(&mut self, i: u32, force: Vec3) -> Result<(), Error> {
        use crate::storage::LOADED;
        if !is_finite3(force) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::Force,
            });
        }
        let n_loads = self.hdr.n_loads;
        let n_nodes = self.hdr.n_nodes;
        let p = self.store.parts_mut();
        let node = p
            .nodes
            .get_mut(..n_nodes)
            .and_then(|n| n.get_mut(i as usize))
            .ok_or(Error::NodeOutOfRange { node: i })?;
        // The list is in node order: entry `at` is node i's, or where it goes.
        let used = p.loads.get_mut(..n_loads).unwrap_or_default();
        let at = used.partition_point(|e| e.node < i);
        let remove = force == [0.0; 3];
        if node.flags & LOADED != 0 {
            if remove {
                used.get_mut(at..).unwrap_or_default().rotate_left(1);
                node.flags &= !LOADED;
                self.hdr.n_loads = n_loads.saturating_sub(1);
            } else if let Some(e) = used.get_mut(at) {
                e.value = force;
            }
        } else if !remove {
            let capacity = p.loads.len();
            let Some(grown) = p.loads.get_mut(..=n_loads) else {
                return Err(Error::TooManyLoads { capacity });
            };
            let tail = grown.get_mut(at..).unwrap_or_default();
            tail.rotate_right(1);
            if let Some(e) = tail.first_mut() {
                *e = crate::storage::NodeEntry {
                    node: i,
                    value: force,
                };
            }
            node.flags |= LOADED;
            self.hdr.n_loads = n_loads + 1;
        }
        self.hdr.forget_energy();
        Ok(())
    }

    /// Removes every external force.
    #[cfg(feature = "loads")]
    pub fn clear_forces(&mut self) {
        self.hdr.forget_energy();
        for n in self.view().nodes.iter_mut() {
            n.flags &= !crate::storage::LOADED;
        }
        self.hdr.n_loads = 0;
    }

    /// Sets all current positions (m); displacements follow as position − rest.
    /// A position, or the displacement it implies, that is not finite is an
    /// [`Error::InvalidParameter`] and leaves the scene unchanged.
    pub fn set_positions(&mut self, positions: &[Vec3]) -> Result<(), Error> {
        let v = self.view();
        check_field(positions, v.nodes, Parameter::Positions, |x0, p| sub(p, x0))?;
        for (n, p) in v.nodes.iter_mut().zip(positions) {
            n.u = sub(*p, n.x0);
        }
        self.hdr.forget_energy();
        self.hdr.placed();
        Ok(())
    }

    /// Sets all displacements from rest (m). A displacement, or the position
    /// it implies, that is not finite is an [`Error::InvalidParameter`] and
    /// leaves the scene unchanged.
    pub fn set_displacements(&mut self, displacements: &[Vec3]) -> Result<(), Error> {
        let v = self.view();
        check_field(displacements, v.nodes, Parameter::Displacements, add)?;
        for (n, u) in v.nodes.iter_mut().zip(displacements) {
            n.u = *u;
        }
        self.hdr.forget_energy();
        self.hdr.placed();
        Ok(())
    }

    /// Sets all velocities (m/s). Fixed nodes keep zero velocity.
    pub fn set_velocities(&mut self, velocities: &[Vec3]) -> Result<(), Error> {
        let v = self.view();
        check_field(velocities, v.nodes, Parameter::Velocities, |_, vel| vel)?;
        for (n, vel) in v.nodes.iter_mut().zip(velocities) {
            n.v = if n.flags & FIXED != 0 { [0.0; 3] } else { *vel };
        }
        self.hdr.forget_energy();
        Ok(())
    }

    /// Back to the rest shape at rest: displacements, velocities, the warm
    /// start and the time are zeroed (constraints and loads are kept).
    pub fn reset_state(&mut self) {
        self.hdr.forget_energy();
        self.hdr.placed();
        let v = self.view();
        for n in v.nodes.iter_mut() {
            n.u = [0.0; 3];
            n.v = [0.0; 3];
        }
        for w in v.work.iter_mut() {
            *w = NodeWork::EMPTY;
        }
        v.hdr.time = 0.0;
        v.hdr.invalidate_coarse();
    }

    /// Advances the scene by one implicit Euler step of `settings().dt`.
    ///
    /// Never panics and never allocates. If the solve produces non-finite
    /// values the step is not applied and [`StepError::Diverged`] is returned:
    /// displacements, velocities, time and the tool are unchanged, while the
    /// elements' world gradients (and `Polar`'s warm-start rotations) are
    /// those the attempted step computed.
    ///
    /// The step is compiled in this crate once for each instruction set of
    /// the target, and runs with the fastest one the CPU supports
    /// ([`InstructionSet::best`]) unless [`Scene::set_instruction_set`] chose
    /// another. Every instruction set gives the same bits.
    pub fn step(&mut self) -> Result<StepStats, StepError> {
        #[cfg(feature = "ground")]
        self.check_ground()?;
        crate::step::step(self.view())
    }

    /// [`Scene::step`] with rigid probes in contact with the body's
    /// surface (feature `probe`): each probe moves from where the last step
    /// left it to its pose ([`Probe::move_to`](crate::Probe::move_to)), the
    /// boundary nodes it reaches are held on it within the implicit solve,
    /// and each probe gets the force the body exerted on it
    /// ([`Probe::force`](crate::Probe::force)). `StepStats::contacts`
    /// counts the nodes held by probes and the ground.
    ///
    /// Refused with [`StepError::TooManyProbes`] for more than
    /// [`MAX_PROBES`](crate::MAX_PROBES), and with
    /// [`StepError::ProbeInsideBody`] for a probe whose first step starts
    /// with a boundary node inside it or lies inside the body. On any error the scene and the
    /// probes are unchanged.
    #[cfg(feature = "probe")]
    pub fn step_with_probes(
        &mut self,
        probes: &mut [crate::Probe],
    ) -> Result<StepStats, StepError> {
        if probes.len() > crate::MAX_PROBES {
            return Err(StepError::TooManyProbes);
        }
        #[cfg(feature = "ground")]
        self.check_ground()?;
        for (k, p) in probes.iter().enumerate().filter(|(_, p)| p.fresh) {
            let inside = self.nodes().iter().position(|n| {
                n.flags & crate::storage::BOUNDARY != 0 && p.starts_around(n.position())
            });
            // Both below `MAX_NODES` and `MAX_PROBES`, 2¹⁶.
            if let Some(node) = inside {
                return Err(StepError::ProbeInsideBody {
                    probe: k as u32,
                    node: Some(node as u32),
                });
            }
            if self.axis_inside(p) {
                return Err(StepError::ProbeInsideBody {
                    probe: k as u32,
                    node: None,
                });
            }
        }
        let mut view = self.view();
        view.probes.list = probes;
        crate::step::step(view)
    }

    /// Whether a probe's axis at its step's start meets an element of the
    /// deformed body: a probe wholly inside it reaches no boundary node.
    #[cfg(feature = "probe")]
    fn axis_inside(&self, p: &crate::Probe) -> bool {
        (0..self.hdr.n_elems).any(|e| {
            self.element_nodes(e).is_some_and(|ids| {
                let mut x = [[0.0; 3]; 4];
                for (xi, &i) in x.iter_mut().zip(&ids) {
                    match self.position(i) {
                        Some(q) => *xi = q,
                        None => return false,
                    }
                }
                p.axis_meets(x)
            })
        })
    }

    /// The instruction set [`Scene::step`] runs with.
    #[must_use]
    pub fn instruction_set(&self) -> InstructionSet {
        self.hdr.isa.asked().unwrap_or_else(InstructionSet::best)
    }

    /// Chooses the instruction set of [`Scene::step`]: `None` (the default)
    /// for the fastest the CPU supports, `Some(isa)` for that one, refused
    /// with [`Error::UnsupportedInstructionSet`] if the CPU (or, without the
    /// `std` feature, the build) does not support it. Every instruction set
    /// gives the same bits: this is for comparing their speed.
    pub fn set_instruction_set(&mut self, isa: Option<InstructionSet>) -> Result<(), Error> {
        self.hdr.isa = match isa {
            None => IsaChoice::Best,
            Some(i) if !i.is_supported() => {
                return Err(Error::UnsupportedInstructionSet { instruction_set: i })
            }
            Some(InstructionSet::Baseline) => IsaChoice::Baseline,
            Some(InstructionSet::Avx2) => IsaChoice::Avx2,
        };
        Ok(())
    }

    /// A 64-bit FNV-1a hash of the bits of every displacement and velocity:
    /// equal hashes mean bit-identical states.
    #[must_use]
    pub fn state_hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for n in self.nodes() {
            for x in n.u.iter().chain(n.v.iter()) {
                for byte in x.to_bits().to_le_bytes() {
                    h ^= u64::from(byte);
                    h = h.wrapping_mul(0x0000_0100_0000_01b3);
                }
            }
        }
        h
    }
}

/// The validated, positively oriented node indices of tetrahedron `e`.
/// Flags the nodes on the mesh's boundary (`BOUNDARY`): those in a face
/// that only one tetrahedron has. Without allocating, in one pass: each
/// tetrahedron adds, to each of its nodes, a hash of the three faces
/// through it, oriented outwards, and the hash changes sign with the
/// orientation. A face two tetrahedra share is oriented oppositely by them
/// (both are positive), so an interior node's sum is exactly zero in
/// wrapping integer arithmetic; a boundary face's hash is left over, and a
/// boundary node's sum is zero only by a 2⁻⁶⁴ accident. The sums run in the
/// solver scratch (`x`'s bits), which is cleared afterwards.
#[cfg(feature = "probe")]
fn mark_boundary(
    nodes: &mut [Node],
    work: &mut [NodeWork],
    tets: &[[u32; 4]],
    positions: &[Vec3],
    options: BuildOptions,
) {
    fn mix(mut z: u64) -> u64 {
        // SplitMix64's finaliser.
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    // Antisymmetric in (a, b), so that a face's sum over its three edges
    // is invariant under rotation and changes sign when it is reversed.
    let edge = |a: u32, b: u32| {
        let (a, b) = (u64::from(a), u64::from(b));
        mix(a)
            .wrapping_mul(mix(b ^ 0xA5A5_0000_0000))
            .wrapping_sub(mix(b).wrapping_mul(mix(a ^ 0xA5A5_0000_0000)))
    };
    let get = |w: &NodeWork| u64::from(w.x[0].to_bits()) | (u64::from(w.x[1].to_bits()) << 32);
    for (e, tet) in tets.iter().enumerate() {
        // Validated by `build`: `oriented` cannot fail here.
        let t = oriented(e, tet, positions, options).unwrap_or([0; 4]);
        // The faces' nodes by constant indices: no bounds check is left.
        let [t0, t1, t2, t3] = t;
        for [a, b, c] in [[t0, t2, t1], [t0, t1, t3], [t0, t3, t2], [t1, t2, t3]] {
            let face = edge(a, b).wrapping_add(edge(b, c)).wrapping_add(edge(c, a));
            for i in [a, b, c] {
                if let Some(w) = work.get_mut(i as usize) {
                    let sum = get(w).wrapping_add(face);
                    w.x[0] = f32::from_bits(sum as u32);
                    w.x[1] = f32::from_bits((sum >> 32) as u32);
                }
            }
        }
    }
    for (n, w) in nodes.iter_mut().zip(work.iter_mut()) {
        if get(w) != 0 {
            n.flags |= crate::storage::BOUNDARY;
        }
        *w = NodeWork::EMPTY;
    }
}

fn oriented(
    e: usize,
    tet: &[u32; 4],
    positions: &[Vec3],
    options: BuildOptions,
) -> Result<[u32; 4], Error> {
    let n = positions.len();
    for (k, &i) in tet.iter().enumerate() {
        if i as usize >= n || i as usize >= MAX_NODES {
            return Err(Error::NodeIndexOutOfRange {
                element: e,
                node: i,
            });
        }
        if tet[..k].contains(&i) {
            return Err(Error::RepeatedNode {
                element: e,
                node: i,
            });
        }
    }
    let mut t = *tet;
    let det = det3(
        edge(positions, &t, 1),
        edge(positions, &t, 2),
        edge(positions, &t, 3),
    );
    if det < 0.0 {
        if !options.reorient {
            return Err(Error::InvertedElement { element: e });
        }
        t.swap(2, 3);
    } else if !(det > 0.0) {
        return Err(Error::DegenerateElement { element: e });
    }
    Ok(t)
}

/// Rest edge `t[k] − t[0]` (m); indices already validated.
fn edge(positions: &[Vec3], t: &[u32; 4], k: usize) -> Vec3 {
    let p = |i: u32| positions.get(i as usize).copied().unwrap_or([0.0; 3]);
    sub(p(t[k]), p(t[0]))
}

/// Whether the QR frame of the rest edges takes its regular path: `ab` and
/// `e1 × ac` have squared lengths that are normal f32 numbers (true for any
/// tetrahedron whose edges lie between ~1e-19 and ~1e19 m and whose face
/// `abc` is not flat).
fn regular_frame(positions: &[Vec3], t: &[u32; 4]) -> bool {
    let e = |k| edge(positions, t, k);
    let (_, [n1, n3]) = qr::frame_regular(e(1), e(2), e(3));
    qr::regular(n1) && qr::regular(n3)
}

/// World gradients (m², 6V₀-scaled) of the rest shape, computed by the step's
/// own kernel so that the rest shape is an exact equilibrium in f32.
fn rest_gradients(
    positions: &[Vec3],
    t: &[u32; 4],
    frame: &qr::Frame,
    lame: [f32; 2],
) -> [Vec3; 3] {
    qr::forces::<true>(
        edge(positions, t, 1),
        edge(positions, t, 2),
        edge(positions, t, 3),
        &frame.local,
        lame,
    )
    .grad
}

/// QR frame of the rest shape and `6V₀ = xb·yc·zd` (m³).
fn rest_frame(positions: &[Vec3], t: &[u32; 4]) -> (qr::Frame, f32) {
    let f = qr::frame(
        edge(positions, t, 1),
        edge(positions, t, 2),
        edge(positions, t, 3),
    );
    let six_v0 = f.local[0] * f.local[2] * f.local[5];
    (f, six_v0)
}

fn check_nodes(nodes: &[u32], n: usize) -> Result<(), Error> {
    match nodes.iter().find(|&&i| i as usize >= n) {
        Some(&i) => Err(Error::NodeOutOfRange { node: i }),
        None => Ok(()),
    }
}

/// `values` has one entry per node, and each entry and the quantity it
/// implies, `implied(x₀, value)` (a position or a displacement), is finite.
fn check_field(
    values: &[Vec3],
    nodes: &[Node],
    parameter: Parameter,
    implied: impl Fn(Vec3, Vec3) -> Vec3,
) -> Result<(), Error> {
    let finite = |(n, v): (&Node, &Vec3)| is_finite3(*v) && is_finite3(implied(n.x0, *v));
    if values.len() != nodes.len() || !nodes.iter().zip(values).all(finite) {
        return Err(Error::InvalidParameter { parameter });
    }
    Ok(())
}

/// Whether an element's Lamé coefficients are finite.
fn lame_finite(stiffness: f32, per_young: [f32; 2]) -> bool {
    let [l, m] = lame(stiffness, per_young);
    l.is_finite() && m.is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BoxMesh;

    crate::capacity! {
        /// Room for the cube.
        struct CubeSlots { nodes: 27, elements: 48 }
    }
    /// A 2×2×2-cell cube (27 nodes, 48 tetrahedra) held at `x = 0`.
    type Cube = StaticScene<CubeSlots>;

    fn cube() -> Cube {
        let mesh = BoxMesh {
            size: [0.1; 3],
            cells: [2; 3],
            tets_per_cell: 6,
        };
        let mut nodes = [[0.0f32; 3]; 27];
        let mut tets = [[0u32; 4]; 48];
        let (n, t) = mesh.generate(&mut nodes, &mut tets).unwrap();
        let mut scene = Cube::new();
        scene
            .build(
                &nodes[..n],
                &tets[..t],
                &Material::DEFAULT,
                BuildOptions::default(),
            )
            .unwrap();
        let held: [u32; 9] = core::array::from_fn(|k| 3 * k as u32);
        scene.fix_nodes(&held).unwrap();
        scene
    }

    /// A U: a bar along x with two prongs up y, held at its bottom. The
    /// coordinate bisection cuts it across y (its longest extent), so the
    /// upper part is both prongs' tops, two pieces joined only through the
    /// bar; the two-level preconditioner's aggregates are nevertheless each
    /// one connected piece of mesh, and none is empty.
    #[cfg(feature = "two-level")]
    #[test]
    fn aggregates_are_connected_pieces_of_mesh() {
        use crate::storage::sealed::Sealed;
        const A: usize = 2;
        crate::capacity! {
            /// Room for the U's box, with two aggregates.
            struct USlots {
                nodes: 126,
                elements: 288,
                preconditioner: Preconditioner::TwoLevel,
                aggregates: A,
            }
        }
        type U = StaticScene<USlots>;
        let mesh = BoxMesh {
            size: [0.6, 0.8, 0.1],
            cells: [6, 8, 1],
            tets_per_cell: 6,
        };
        let mut nodes = [[0.0f32; 3]; 126];
        let mut tets = [[0u32; 4]; 288];
        let (n, t) = mesh.generate(&mut nodes, &mut tets).unwrap();
        // Keep the bar (y < 0.1) and the prongs (x < 0.1, x > 0.5), then
        // only the nodes those tetrahedra use.
        let centre = |t: &[u32; 4]| {
            let c = t.map(|i| nodes[i as usize]);
            [0, 1].map(|k| (c[0][k] + c[1][k] + c[2][k] + c[3][k]) / 4.0)
        };
        let kept: std::vec::Vec<[u32; 4]> = tets[..t]
            .iter()
            .filter(|t| {
                let [x, y] = centre(t);
                y < 0.1 || !(0.1..0.5).contains(&x)
            })
            .copied()
            .collect();
        let mut index = [u32::MAX; 126];
        let mut used = std::vec::Vec::new();
        for i in kept.iter().flatten() {
            if index[*i as usize] == u32::MAX {
                index[*i as usize] = used.len() as u32;
                used.push(nodes[*i as usize]);
            }
        }
        let kept: std::vec::Vec<[u32; 4]> =
            kept.iter().map(|t| t.map(|i| index[i as usize])).collect();
        assert!(used.len() < n);
        let mut scene = U::new();
        scene
            .build(&used, &kept, &Material::DEFAULT, BuildOptions::default())
            .unwrap();
        let held: std::vec::Vec<u32> = (0..used.len() as u32)
            .filter(|&i| used[i as usize][1] < 1e-6)
            .collect();
        scene.fix_nodes(&held).unwrap();
        scene
            .set_settings(Settings {
                preconditioner: Preconditioner::TwoLevel,
                warm_start: true,
                cg_iterations: 3,
                gravity: [-9.81, 0.0, 0.0],
                ..Settings::default()
            })
            .unwrap();
        scene.step().unwrap();
        let p = scene.store.parts_mut();
        let labels: std::vec::Vec<u32> =
            p.blocks[..used.len()].iter().map(|b| b.aggregate).collect();
        // Components of each label: union-find over the edges of the
        // tetrahedra whose two ends share it.
        let mut parent: std::vec::Vec<usize> = (0..used.len()).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                i = p[i];
            }
            i
        }
        for t in &kept {
            for a in t {
                for b in t {
                    let (a, b) = (*a as usize, *b as usize);
                    if labels[a] == labels[b] && labels[a] != u32::MAX {
                        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                        parent[ra] = rb;
                    }
                }
            }
        }
        for k in 0..A as u32 {
            let mut roots: std::vec::Vec<usize> = (0..used.len())
                .filter(|&i| labels[i] == k)
                .map(|i| root(&mut parent, i))
                .collect();
            roots.sort_unstable();
            roots.dedup();
            assert_eq!(roots.len(), 1, "aggregate {k}: {} pieces", roots.len());
        }
        // Every free node has an aggregate, no fixed one has.
        for (i, l) in labels.iter().enumerate() {
            assert_eq!(*l == u32::MAX, held.contains(&(i as u32)), "node {i}");
        }
    }

    /// An empty scene's header is all zero bits, field by field (what puts
    /// a `static` scene in `.bss`; `.ci/firmware.sh` checks the section of
    /// a real one), and reports the default settings.
    #[test]
    fn an_empty_scene_is_zero_bits_and_has_the_default_settings() {
        let h = Cube::new().hdr;
        let s = h.settings;
        let floats = [h.poisson, h.density, s.dt, s.cg_tolerance]
            .into_iter()
            .chain([s.rayleigh_mass, s.rayleigh_stiffness, s.friction_damping])
            .chain(s.gravity);
        assert!(floats.map(f32::to_bits).all(|b| b == 0));
        assert_eq!(
            (h.n_nodes, h.n_elems, h.inverted, h.time.to_bits()),
            (0, 0, 0, 0)
        );
        assert_eq!((s.method as u8, s.cg_iterations), (0, 0));
        assert!(!s.warm_start && !h.settings_valid && !h.any_fixed);
        #[cfg(feature = "ground")]
        assert!(h.ground.is_none());
        #[cfg(feature = "tool")]
        {
            let t = h.tool;
            assert_eq!((t.k_node.to_bits(), t.count), (0, 0));
            assert!(t.target.iter().all(|x| x.to_bits() == 0));
        }
        #[cfg(feature = "loads")]
        assert_eq!(h.n_loads, 0);
        // A storage without preconditioner slots steps with the paper's
        // CG; the rest of the defaults are `Settings::new()`'s, as far as
        // the build has them.
        let defaults = Cube::new().default_settings();
        assert_eq!(*Cube::new().settings(), defaults);
        assert_eq!(
            defaults,
            Settings::with_preconditioner(crate::Preconditioner::Mass).compiled()
        );
        assert_eq!(
            defaults,
            Settings {
                preconditioner: crate::Preconditioner::Mass,
                cg_iterations: 5,
                warm_start: false,
                ..Settings::new().compiled()
            }
        );
    }

    /// The defaults are the same in every build; made `compiled`, every
    /// build runs them, and `compiled` keeps settings the build runs.
    #[test]
    fn the_defaults_are_the_same_in_every_build_and_compiled_runs_them() {
        let d = Settings::new();
        assert_eq!(
            (d.method, d.preconditioner, d.cg_iterations, d.warm_start),
            (Method::QrInvertible, Preconditioner::TwoLevel, 4, true)
        );
        assert!(d.energy_guard && d.free_rotation);
        assert_eq!(
            d.validate().is_ok(),
            cfg!(all(
                feature = "qr-invertible",
                feature = "energy-guard",
                feature = "free-rotation"
            ))
        );
        let c = d.compiled();
        assert_eq!(c.validate(), Ok(()));
        assert!(c.preconditioner.is_compiled());
        assert_eq!(c.compiled(), c);
        assert_eq!(
            c == d,
            cfg!(all(
                feature = "qr-invertible",
                feature = "two-level",
                feature = "energy-guard",
                feature = "free-rotation"
            ))
        );
    }

    /// A scene whose settings were never set steps with the defaults: the
    /// bits of one given them explicitly.
    #[test]
    fn unset_settings_step_as_the_defaults() {
        let mut unset = cube();
        let mut given = cube();
        given.set_settings(given.default_settings()).unwrap();
        for _ in 0..3 {
            let (a, b) = (unset.step().unwrap(), given.step().unwrap());
            assert_eq!(a.cg_iterations, b.cg_iterations);
            assert_eq!(a.cg_residual.to_bits(), b.cg_residual.to_bits());
        }
        assert_eq!(unset.state_hash(), given.state_hash());
        assert_eq!(unset.time(), 3.0 * f64::from(Settings::default().dt));
        // Where the default preconditioner needs slots the storage lacks,
        // asking for it is refused and changes nothing.
        if !given.supports(crate::Preconditioner::DEFAULT) {
            assert_eq!(
                given.set_settings(Settings::new().compiled()),
                Err(Error::PreconditionerUnavailable {
                    preconditioner: crate::Preconditioner::DEFAULT
                })
            );
        }
        assert_eq!(unset.settings(), given.settings());
    }

    /// Every method can be asked for in every build; one whose feature is
    /// off is refused by each setter that takes a method, and nothing
    /// changes (CI runs the core's unit tests with `qr` alone, where three
    /// methods are missing).
    #[test]
    fn a_method_not_compiled_in_is_refused_and_changes_nothing() {
        let mut scene = cube();
        let mut twin = cube();
        scene.step().unwrap();
        twin.step().unwrap();
        let settings = *scene.settings();
        for method in Method::VARIANTS {
            let with = Settings { method, ..settings };
            let results = [scene.set_settings(with), scene.set_method(method)];
            if method.is_compiled() {
                assert_eq!(results, [Ok(()), Ok(())], "{method:?}");
                assert_eq!(scene.settings().method, method);
                scene.set_settings(settings).unwrap();
            } else {
                let refused = Err(Error::MethodNotCompiled { method });
                assert_eq!(results, [refused, refused], "{method:?}");
                assert_eq!(with.validate(), refused);
            }
            assert_eq!(*scene.settings(), settings, "{method:?}");
            assert_eq!(scene.state_hash(), twin.state_hash(), "{method:?}");
        }
        // The refusals left nothing behind that the next step sees.
        scene.step().unwrap();
        twin.step().unwrap();
        assert_eq!(scene.state_hash(), twin.state_hash());
    }
}
