//! # corofem
//!
//! A `no_std`, allocation-free, fixed-capacity real-time soft-body solver:
//! co-rotational linear finite elements on tetrahedra, after Nesme, Payan and
//! Faure, *Efficient, physically plausible finite elements* (Eurographics 2005).
//! All arithmetic is f32 in a fixed order, so a scene gives the same bits on
//! x86_64, wasm32 and Cortex-M.
//!
//! ## The step
//!
//! One linearised implicit Euler step, as a pipeline of named stages (each a
//! function of its own module; a model whose feature is off compiles its
//! stages to nothing):
//!
//! ```text
//!  detect     contact   which obstacle (ground, probe) holds each node; stick or slide
//!  carry      contact   a body the ground holds: its carried guess, its rigid lift
//!  guess      step      free fall, warm start, held normals; the product's input
//!  element    pass      QR frame → B(current) → f_el, world gradients g, −K (v + x₀)
//!  prepare    precond   node blocks, aggregates' rotations, coarse factor
//!  residual   step      b = h (f_el + f_ext + m g − α_M M v) + h(α_K + h)(−K v) − A x₀
//!                       (tool spring, loads, kinetic friction, the guard's ledger)
//!  guard      guard     an energy excess taken out of the starting velocity
//!  solve      cg        A Δv = b, A = (1 + hα_M) M + h(α_K + h) K, filtered by S
//!                       (cg_iterations, more until the energy certificate holds,
//!                       else a Galerkin step; K d element by element, never
//!                       assembled); the free body's angular momentum kept
//!  relax      contact   a push out of an obstacle taken back out of the velocity
//!  candidates step      v' = v + Δv, u' = u + h v'
//!  turn       turn      a free body's rotation made a rotation
//!  impact     contact   a landing body stopped as a whole
//!  impulses   contact   landings, contact and friction impulses, support and tool
//!                       forces; the step is refused unless all is finite
//!  commit     step      the state, the contacts' flags, the guard's reference
//! ```
//!
//! ## Physical plausibility
//!
//! * Rotational invariance: a rigidly rotated body has no elastic force.
//! * Newton: each element's forces sum to zero exactly (`f_a = −Σ fᵢ`).
//! * Euler: with `B` from the current shape (`Method::Qr`,
//!   `Method::QrInvertible`) they have no net torque; `Method::QrRestB`
//!   (SOFA's default) shows the ghost torques.
//! * Inversion: `Method::QrInvertible` turns an inverted
//!   element with the rotation closest to its deformation gradient, which
//!   pushes it back through itself.
//! * Momentum: lumped-mass-preconditioned CG keeps the linear and angular
//!   momentum of an isolated body at any iteration count.
//!
//! ## Example
//!
//! ```
//! use corofem::{BoxMesh, BuildOptions, Material, Settings, StaticScene};
//!
//! // A 1 m × 0.2 m × 0.2 m beam held at x = 0.
//! let mesh = BoxMesh { size: [1.0, 0.2, 0.2], cells: [10, 2, 2], tets_per_cell: 6 };
//! let mut nodes = [[0.0f32; 3]; 99];
//! let mut tets = [[0u32; 4]; 240];
//! let (n, t) = mesh.generate(&mut nodes, &mut tets).unwrap();
//!
//! // The scene's capacity: up to 99 nodes and 240 tetrahedra.
//! corofem::capacity! { struct Beam { nodes: 99, elements: 240 } }
//! static mut SCENE: StaticScene<Beam> = StaticScene::new(); // fits in a static
//! let mut scene = StaticScene::<Beam>::new();
//! let material = Material { young: 1.0e6, poisson: 0.3, density: 1000.0 };
//! scene.build(&nodes[..n], &tets[..t], &material, BuildOptions::default()).unwrap();
//! let fixed: Vec<u32> = (0..n as u32).filter(|&i| nodes[i as usize][0] == 0.0).collect();
//! scene.fix_nodes(&fixed).unwrap();
//! // The defaults this storage can run (it has no preconditioner slots).
//! scene.set_settings(Settings { dt: 1.0e-3, ..scene.default_settings() }).unwrap();
//! for _ in 0..100 {
//!     let stats = scene.step().unwrap();
//!     assert_eq!(stats.inverted, 0);
//! }
//! ```
//!
//! ## Features
//!
//! Every feature is additive. Names that start with `_` tune or demonstrate
//! and are not part of the stable interface.
//!
//! | feature | what |
//! |---|---|
//! | `qr` (default) | the paper's QR method |
//! | `qr-invertible` (default) | the default method: the paper's QR method, with inverted elements turned by the closest proper rotation (brings `qr`) |
//! | `polar`, `linear` | the other element methods |
//! | `qr-rest-b` | SOFA's QR method with `B` frozen at rest: a demonstration of ghost torques |
//! | `ground`, `tool`, `loads`, `statics`, `diagnostics` | ground contact, haptic tool, constant nodal forces, static solve, energies and momenta (and [`StepStats::elastic_energy`]) |
//! | `energy-guard` (default) | the energy guard ([`Settings::energy_guard`]): a step takes out of the body's deformation the energy the previous step made beyond the work of moving the tool's target, while nothing else did work on it and elements were inverted |
//! | `free-rotation` (default) | a body that nothing holds (no fixed node, tool or contact) and that moves as one over a step turns by a rigid rotation, the implicit midpoint rule of its rotation, instead of moving along its tangents, which stretches a spinning body by `(h \|ω\|)²/2` a step; keeps the momenta and the rigid kinetic energy ([`Settings::free_rotation`]) |
//! | `two-level` (default) | the block-Jacobi and two-level preconditioners ([`Preconditioner`]); two-level, 4 CG iterations from a warm start, is then the default solver |
//! | `probe` | rigid spheres and capsules pressing on the body ([`Scene::step_with_probes`]; brings `ground`) |
//! | `coupling` | a haptic virtual coupling between a device and a probe ([`Coupling`]; brings `probe`) |
//! | `friction` | Coulomb friction, static and kinetic, for the ground and probes ([`Friction`]; brings `ground`) |
//! | `surface` | embedded surfaces: a detailed triangle surface bound to the tetrahedra and moved with them ([`Scene::bind_surface`], [`Scene::update_surface`], [`vertex_normals`]) |
//! | `alloc` | `VecStorage` and `VecScene`: storage in `Vec`s, sized at run time (the solver never allocates) |
//! | `full` | all of the above |
//! | `libm` (default) / `micromath` | math backend: correctly rounded / fast and approximate; `libm` wins when both are on, one is needed |
//! | `fpu-sqrt` | square root with the FPU's `vsqrt.f32` on bare-metal Arm hard-float targets (Cortex-M4F/M7), bit-identical to `libm` |
//! | `fpu-product` | the CG's stiffness product in FPU assembly (`vldm`/`vstm`) on the same targets, bit-identical to the Rust product |
//! | `_fpu-product-vmul` | tuning: `fpu-product` with `vmul` + `vadd` instead of `vmla`: more instructions, fewer cycles on a Cortex-M4 |
//! | `std` | [`Scene::step`] detects AVX2 on x86_64 once per process and uses it when present ([`InstructionSet`]) |
//! | `defmt` | `defmt::Format` on public types |
//!
//! Every [`Method`] exists in every build; a scene refuses one whose feature
//! is off ([`Error::MethodNotCompiled`]), and [`Method::COMPILED`] lists the
//! others.
#![no_std]
// No unsafe code, except the square root instruction (math.rs: SSE's
// `sqrtss` intrinsic on x86, the FPU's `vsqrt.f32` behind `fpu-sqrt`), the
// stiffness product in FPU assembly behind `fpu-product` (backend/fpu_product.rs) and
// the x86_64 backends (backend/: SSE2 and AVX2 intrinsics, 16-byte loads and
// stores inside checked slots, AVX2 only behind a token that proves the CPU
// has it), each allowed where it is and nowhere else.
#![deny(unsafe_code)]
#![warn(missing_docs)]
#![cfg_attr(docsrs, feature(doc_cfg))]
// `!(x > 0.0)` is the NaN-safe way to reject a value: it is true for NaN,
// which `x <= 0.0` is not. We use it on purpose throughout.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// `x % LANES` is `0` where a block holds one element (`LANES == 1`, e.g. a
// Cortex-M4F): the same code serves both, on purpose.
#![allow(clippy::modulo_one)]

#[cfg(feature = "alloc")]
extern crate alloc;
// `std` only to ask the CPU which instruction sets it has (feature `std`).
#[cfg(any(feature = "std", test))]
extern crate std;

mod backend;
mod cg;
mod contact;
mod element;
mod error;
mod guard;
mod lanes;
mod material;
mod math;
mod mesh_gen;
mod pass;
#[cfg(feature = "two-level")]
mod precond;
mod rigid;
mod scene;
mod settings;
#[cfg(feature = "two-level")]
mod slots;
mod state;
mod step;
mod storage;
#[cfg(feature = "free-rotation")]
mod turn;

#[cfg(feature = "coupling")]
mod coupling;
#[cfg(feature = "diagnostics")]
mod diagnostics;
#[cfg(feature = "nalgebra")]
pub mod na;
#[cfg(feature = "statics")]
mod statics;
#[cfg(feature = "surface")]
mod surface;
#[cfg(feature = "tool")]
mod tool;

pub use backend::InstructionSet;
pub use element::{element_blocks, ElementBlock, Method};
/// Elements per [`ElementBlock`] on this target: 8 where the element passes
/// run in vector lanes (x86, x86_64, AArch64, wasm32 with `simd128`), 1
/// elsewhere (e.g. a Cortex-M4F).
pub const ELEMENTS_PER_BLOCK: usize = lanes::LANES;
#[cfg(feature = "friction")]
pub use contact::ground::Friction;
#[cfg(feature = "ground")]
pub use contact::ground::Plane;
#[cfg(feature = "probe")]
pub use contact::probe::{Probe, MAX_PROBES};
#[cfg(feature = "coupling")]
pub use coupling::Coupling;
pub use error::{Error, Parameter, StepError};
pub use material::Material;
pub use math::Vec3;
pub use mesh_gen::BoxMesh;
#[cfg(feature = "alloc")]
pub use scene::VecScene;
pub use scene::{BuildOptions, Scene, StaticScene};
pub use settings::{Preconditioner, Settings, StepStats};
#[cfg(feature = "two-level")]
pub use slots::{
    aggregates_for, coarse_blocks_for, Aggregate, CoarseBlock, NodeBlock, MAX_AGGREGATES,
    NODES_PER_AGGREGATE,
};
#[cfg(feature = "statics")]
pub use statics::{NewtonStats, StaticSettings};
#[cfg(feature = "alloc")]
pub use storage::VecStorage;
pub use storage::{
    ArrayStorage, Capacity, Node, NodeEntry, NodeWork, SliceStorage, SlotArray, Slots, Storage,
};
#[cfg(feature = "surface")]
pub use surface::{check_surface, surface_scratch_len, vertex_normals, BindStats, SurfaceBinding};

/// The README's code example, compiled and run as a doctest (it uses the
/// tool).
#[cfg(all(doctest, feature = "tool"))]
#[doc = include_str!("../../README.md")]
pub struct ReadmeDoctests;
