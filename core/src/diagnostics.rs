//! Diagnostics: energies, momenta and the internal forces, for checking the
//! physical laws. None of this runs in the step.

use crate::error::Parameter;
use crate::math::{add, axpy, cross, dot, scale, Vec3};
use crate::pass;
use crate::storage::Storage;
use crate::Scene;

impl<S: Storage> Scene<S> {
    /// Kinetic energy `½ Σ m |v|²` (J).
    #[must_use]
    pub fn kinetic_energy(&self) -> f32 {
        0.5 * self
            .positions_masses_velocities()
            .fold(0.0, |e, (_, m, v)| e + m * dot(v, v))
    }

    /// Linear momentum `Σ m v` (kg·m/s).
    #[must_use]
    pub fn momentum(&self) -> Vec3 {
        self.positions_masses_velocities()
            .fold([0.0; 3], |p, (_, m, v)| axpy(p, m, v))
    }

    /// Angular momentum about the origin `Σ x × m v` (kg·m²/s).
    #[must_use]
    pub fn angular_momentum(&self) -> Vec3 {
        self.positions_masses_velocities()
            .fold([0.0; 3], |l, (x, m, v)| add(l, scale(cross(x, v), m)))
    }

    fn positions_masses_velocities(&self) -> impl Iterator<Item = (Vec3, f32, Vec3)> + '_ {
        // `as u32`: a scene has at most 65 536 nodes.
        (0..self.node_count() as u32)
            .filter_map(|i| Some((self.position(i)?, self.mass(i)?, self.velocity(i)?)))
    }

    /// Elastic energy of the current shape with the current method (J),
    /// `Σ ½ ε̃ᵀ D' ε̃` over the elements. Leaves the state untouched.
    pub fn elastic_energy(&mut self) -> f32 {
        let v = self.view();
        let method = v.hdr.settings.method;
        pass::forces_outside_step(
            false,
            method,
            v.hdr.per_young(),
            v.nodes,
            v.elems,
            v.n_elems,
            &mut |_, _| {},
        )
        .energy
    }

    /// Internal elastic forces on every node (N) into `out` (its first
    /// `node_count()` entries), with the current method. Leaves the state
    /// untouched. Returns the number of inverted elements.
    pub fn elastic_forces(&mut self, out: &mut [Vec3]) -> Result<u32, crate::Error> {
        let v = self.view();
        if out.len() < v.nodes.len() {
            return Err(crate::Error::InvalidParameter {
                parameter: Parameter::ForcesOut,
            });
        }
        for f in out.iter_mut() {
            *f = [0.0; 3];
        }
        let method = v.hdr.settings.method;
        let totals = pass::forces_outside_step(
            false,
            method,
            v.hdr.per_young(),
            v.nodes,
            v.elems,
            v.n_elems,
            &mut |i, f| {
                if let Some(o) = out.get_mut(i) {
                    *o = add(*o, f);
                }
            },
        );
        Ok(totals.inverted)
    }

    /// The stiffness product `out = −K d` (N, for `d` in m) of the operator
    /// CG iterates on, with the world gradients of the last force evaluation
    /// (the last step, or the build): the product each CG iteration runs,
    /// exposed to check it against an assembled matrix and to time it
    /// (`cargo bench -p corofem-bench --bench core`). `d` and `out` hold one
    /// vector per node (their first `node_count()` entries are used).
    ///
    /// Uses the solver's scratch (`NodeWork`'s search direction and product),
    /// never the state; a non-finite or too short `d` is
    /// [`Parameter::ProductInput`], a too short `out` [`Parameter::ProductOut`].
    pub fn stiffness_product(&mut self, d: &[Vec3], out: &mut [Vec3]) -> Result<(), crate::Error> {
        let v = self.view();
        let n = v.nodes.len();
        let bad = |parameter| Err(crate::Error::InvalidParameter { parameter });
        let Some(d) = d.get(..n) else {
            return bad(Parameter::ProductInput);
        };
        let Some(out) = out.get_mut(..n) else {
            return bad(Parameter::ProductOut);
        };
        if !d.iter().all(|x| crate::math::is_finite3(*x)) {
            return Err(crate::Error::InvalidParameter {
                parameter: Parameter::ProductInput,
            });
        }
        for (w, x) in v.work.iter_mut().zip(d) {
            w.d = *x;
            w.q = [0.0; 3];
        }
        pass::stiffness_outside_step(v.hdr.per_young(), v.elems, v.n_elems, v.work);
        for (o, w) in out.iter_mut().zip(v.work.iter()) {
            *o = w.q;
        }
        Ok(())
    }
}
