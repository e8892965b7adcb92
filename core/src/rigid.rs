//! A body's rigid motions: its centre of mass and inertia at the step's
//! start ([`Rigid`]), the rigid motion of a field's momentum, the Cayley
//! rotation ([`Turn`]), and how much of a body moves as one in a step
//! ([`reach`]). The preconditioners keep a free body's rigid modes exact
//! with it, the guard keeps its momentum, the ground lands and lifts it as
//! one, and `turn` rotates it.

use crate::math::{add, axpy, cross, dot, scale, solve3, sub, Vec3};
use crate::storage::{Node, NodeWork, FIXED};

/// Makes the angular momentum of an isolated body's new velocity
/// `v' = v + Δv` (`Δv` in `x`) the exact step's: with internal forces and
/// products free of net torque, `(1 + h α_M) L' = L + h τ` about the centre
/// of mass (the guard's `δ` has no angular momentum). The difference is a
/// rotation about the centre of mass, `ω = I⁻¹ (Σ r × m (v' − v/(1 + h α_M))
/// − h τ/(1 + h α_M))`, taken out of `Δv`; the linear momentum is kept.
pub(crate) fn keep_angular_momentum(
    body: &Rigid,
    nodes: &[Node],
    work: &mut [NodeWork],
    mass_coef: f32,
    torque_h: Vec3,
) {
    let Some(inertia) = body.inertia else {
        return;
    };
    let decay = 1.0 - 1.0 / mass_coef;
    let (_, omega) = body.fit(nodes, work, |n, w| {
        scale(add(w.x, scale(n.v, decay)), n.mass)
    });
    let external = solve3(&inertia, scale(torque_h, 1.0 / mass_coef)).unwrap_or([0.0; 3]);
    let omega = sub(omega, external);
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        if n.flags & FIXED == 0 {
            w.x = sub(w.x, cross(omega, sub(n.position(), body.c)));
        }
    }
}

/// The rigid motions of an isolated body about its centre of mass `c` at
/// the step's start: translations, and with `rotations`, `ω × (p − c)`.
#[derive(Clone, Copy)]
pub(crate) struct Rigid {
    pub(crate) c: Vec3,
    pub(crate) inv_mass: f32,
    /// `I = Σ m (|p − c|² I − (p − c)(p − c)ᵀ)`, with rotations.
    pub(crate) inertia: Option<crate::math::Mat3>,
    /// `Σ m (p − c)`, zero but for round-off.
    first_moment: Vec3,
}

/// Adds a point mass `m` at `r` to the inertia `Σ m (|r|² I − r rᵀ)`.
#[inline(always)]
pub(crate) fn add_inertia(inertia: &mut crate::math::Mat3, m: f32, r: Vec3) {
    let r2 = dot(r, r);
    for (a, row) in inertia.iter_mut().enumerate() {
        for (b, iab) in row.iter_mut().enumerate() {
            let delta = if a == b { r2 } else { 0.0 };
            *iab += m * (delta - r[a] * r[b]);
        }
    }
}

/// A rigid motion `(v, ω)`.
pub(crate) type Motion = (Vec3, Vec3);

impl Rigid {
    /// `None` for a body without mass.
    pub(crate) fn new(nodes: &[Node], rotations: bool) -> Option<Self> {
        let (mut mass, mut mc) = (0.0f32, [0.0f32; 3]);
        for n in nodes {
            mass += n.mass;
            mc = axpy(mc, n.mass, n.position());
        }
        if !(mass > 0.0) {
            return None;
        }
        let c = scale(mc, 1.0 / mass);
        let mut inertia = [[0.0f32; 3]; 3];
        let mut first_moment = [0.0f32; 3];
        for n in nodes {
            let r = sub(n.position(), c);
            first_moment = axpy(first_moment, n.mass, r);
            add_inertia(&mut inertia, n.mass, r);
        }
        Some(Self {
            c,
            inv_mass: 1.0 / mass,
            inertia: rotations.then_some(inertia),
            first_moment,
        })
    }

    crate::backend::isa_inline!(
        /// The rigid motion whose momentum is that of the field `f(node, work)`
        /// (a momentum per node, or a force): `v = Σ f / Σ m` and
        /// `ω = I⁻¹ Σ (p − c) × (f − m v)`, in one pass over the nodes.
        pub(crate) fn fit(
            &self,
            nodes: &[Node],
            work: &[NodeWork],
            f: impl Fn(&Node, &NodeWork) -> Vec3,
        ) -> Motion {
            let (mut lin, mut ang) = ([0.0f32; 3], [0.0f32; 3]);
            for (n, w) in nodes.iter().zip(work.iter()) {
                let fi = f(n, w);
                lin = add(lin, fi);
                if self.inertia.is_some() {
                    ang = add(ang, cross(sub(n.position(), self.c), fi));
                }
            }
            let vel = scale(lin, self.inv_mass);
            let omega = self
                .inertia
                .and_then(|i| solve3(&i, sub(ang, cross(self.first_moment, vel))))
                .unwrap_or([0.0; 3]);
            (vel, omega)
        }
    );

    /// The velocity of the centre of mass of the field `f(node, work)` (a
    /// momentum per node), and, with rotations, its angular momentum about
    /// `c` less the round-off of `Σ m (p − c)`: `I ω` of [`Rigid::fit`],
    /// whose loop this repeats (`fit` calling it measured 2 instructions
    /// per tet-step more on the Cortex-M4F, in images without this feature).
    #[cfg(feature = "free-rotation")]
    #[inline(always)]
    pub(crate) fn momenta(
        &self,
        nodes: &[Node],
        work: &[NodeWork],
        f: impl Fn(&Node, &NodeWork) -> Vec3,
    ) -> (Vec3, Vec3) {
        let (mut lin, mut ang) = ([0.0f32; 3], [0.0f32; 3]);
        for (n, w) in nodes.iter().zip(work.iter()) {
            let fi = f(n, w);
            lin = add(lin, fi);
            if self.inertia.is_some() {
                ang = add(ang, cross(sub(n.position(), self.c), fi));
            }
        }
        let vel = scale(lin, self.inv_mass);
        (vel, sub(ang, cross(self.first_moment, vel)))
    }

    /// The motion `m` at node `n`.
    #[inline(always)]
    pub(crate) fn at(&self, n: &Node, m: Motion) -> Vec3 {
        add(m.0, cross(m.1, sub(n.position(), self.c)))
    }

    /// `a` at node `n` less the rigid motion `m`.
    #[inline(always)]
    pub(crate) fn less_rigid(&self, n: &Node, a: Vec3, m: Motion) -> Vec3 {
        sub(a, self.at(n, m))
    }

    crate::backend::isa_inline!(
        /// Completes a preconditioner `P` made exact on the rigid modes `R`:
        /// `z = Π P⁻¹ Πᵀ r + R (RᵀAR)⁻¹ Rᵀ r`, with `Π = I − R (RᵀMR)⁻¹ RᵀM`
        /// and `RᵀAR = (1 + h α_M) RᵀMR` (`K R = 0`). Both the rigid modes and
        /// their `M`-orthogonal complement are then invariant under `P⁻¹A`, so
        /// every CG iterate keeps the exact step's response to the rigid modes,
        /// as the mass preconditioner does. The caller has set every `q` to
        /// `P⁻¹ Πᵀ r`, that is `P⁻¹` of `rᵢ − mᵢ force(pᵢ)`, where `force` is the
        /// [`Rigid::fit`] of `r` (the rigid motion of the residual's net force
        /// and torque); this makes `q = z` and returns `rᵀz`.
        #[cfg(feature = "two-level")]
        pub(crate) fn finish(
            &self,
            nodes: &[Node],
            work: &mut [NodeWork],
            mass_coef: f32,
            force: Motion,
        ) -> f32 {
            // Π z̃ = z̃ less its rigid motion, plus the rigid modes' exact part.
            let kept = self.fit(nodes, work, |n, w| scale(w.q, n.mass));
            let mut rz = 0.0f32;
            for (n, w) in nodes.iter().zip(work.iter_mut()) {
                let z = self.less_rigid(n, w.q, kept);
                w.q = axpy(z, 1.0 / mass_coef, self.at(n, force));
                rz += dot(w.r, w.q);
            }
            rz
        }
    );
}

/// The Cayley rotation of `a`: by the angle `2 atan(|a|/2)` about `a`, as
/// the unit quaternion `(w, q)`, `q = w a/2`, `w = 1/√(1 + |a|²/4)`; for a
/// small `a`, the rotation by `a` to second order.
#[cfg(any(feature = "ground", feature = "free-rotation"))]
#[derive(Clone, Copy)]
pub(crate) struct Turn {
    w: f32,
    q: Vec3,
}

#[cfg(any(feature = "ground", feature = "free-rotation"))]
impl Turn {
    pub(crate) fn cayley(a: Vec3) -> Self {
        let half = scale(a, 0.5);
        let w = 1.0 / crate::math::sqrt(1.0 + dot(half, half));
        Self {
            w,
            q: scale(half, w),
        }
    }

    /// `R y = y + 2 w (q × y) + 2 q × (q × y)`.
    #[inline(always)]
    pub(crate) fn apply(&self, y: Vec3) -> Vec3 {
        let qy = cross(self.q, y);
        add(
            y,
            add(scale(qy, 2.0 * self.w), scale(cross(self.q, qy), 2.0)),
        )
    }

    #[cfg(feature = "free-rotation")]
    pub(crate) fn inverse(self) -> Self {
        Self {
            w: self.w,
            q: scale(self.q, -1.0),
        }
    }
}

/// How much of a body moves as one during a step of length `h`, from its
/// [`wave`] `ratio2 = (c h / L)²`: the distance `c h` a pressure wave
/// travels over the body's radius of gyration `L = √(tr I / 2M)`, capped
/// at one. The limit of the rigid part of an impact: a body without
/// stiffness (`c = 0`) takes none, each node lands alone; a stiff body over
/// a long step lands whole.
#[inline(always)]
pub(crate) fn share(ratio2: f32) -> f32 {
    if ratio2 >= 1.0 {
        1.0
    } else {
        crate::math::sqrt(ratio2.max(0.0))
    }
}

/// `(c h / L)²`, the square of the distance a pressure wave travels in a
/// step over the body's radius of gyration ([`share`], uncapped; 0 for a
/// body without inertia). `c² = (λ + 2μ) / ρ` with the volume-weighted
/// mean Young's modulus, `Σ E V / Σ V`, and `ρ = M / Σ V`:
/// `c² = (λ' + 2μ') Σ E V / M` (`λ'`, `μ'` per unit `E`). An element's
/// `E V` is its stored `E / (36 V₀)` times `(6 V₀)²`.
pub(crate) fn wave(
    body: &Rigid,
    elems: &[crate::element::ElementBlock],
    n_elems: usize,
    per_young: [f32; 2],
    h: f32,
) -> f32 {
    let mut ev = 0.0f32;
    // Unused lanes of the last block have zero stiffness.
    for blk in elems.iter().take(n_elems.div_ceil(crate::lanes::LANES)) {
        for j in 0..crate::lanes::LANES {
            let el = blk.get(j);
            ev += el.stiffness * el.six_v0() * el.six_v0();
        }
    }
    let Some(inertia) = body.inertia else {
        return 0.0;
    };
    let trace = inertia[0][0] + inertia[1][1] + inertia[2][2];
    // (c h / L)² = (λ' + 2μ') Σ E V h² / M · 2M / tr I.
    (per_young[0] + 2.0 * per_young[1]) * ev * h * h * 2.0 / trace
}
