//! Contact: what holds a node during a step, and what the step does about it.
//!
//! The obstacles are the ground ([`ground`], feature `ground`) and rigid
//! probes ([`probe`], feature `probe`), each seen by the step as a
//! `Contact` plane per node: [`Obstacles`] finds the one
//! that holds a node and gives its plane, so a new obstacle shape is one
//! more source of planes here and nothing in the step. A held node's normal
//! velocity change is prescribed within the implicit solve and filtered from
//! CG's directions (`Obstacles::filter`); a sticking node's whole velocity
//! is (friction). After the solve the unfiltered residual is each held
//! node's impulse: one that would pull releases the node for the next step,
//! one beyond the static cone lets it slide from the next step.
//!
//! The step's contact stages, in order:
//!
//! * [`detect`]: which obstacle holds each node, and whether it sticks;
//! * [`carry`]: for a body the ground alone holds, the rigid motion of its
//!   guess (`PlaneFit`) and its rigid push out of the ground (`Lift`);
//! * [`relax`](relax()): the push out taken back out of the velocity;
//! * [`impact`](impact()): a landing body stopped as a whole;
//! * [`land`] and [`impulse`], per node: nodes that end inside an obstacle
//!   stopped, the held nodes' impulses and friction, the support force;
//! * [`commit`]: the flags the next step starts from.
//!
//! Without the feature `ground` there is no obstacle and each stage
//! compiles to nothing.

#[cfg(feature = "ground")]
pub(crate) mod ground;
#[cfg(feature = "ground")]
mod impact;
#[cfg(feature = "ground")]
mod lift;
#[cfg(feature = "ground")]
mod plane_fit;
#[cfg(feature = "probe")]
pub(crate) mod probe;
#[cfg(feature = "ground")]
mod relax;
#[cfg(feature = "ground")]
pub(crate) mod whole;

#[cfg(feature = "friction")]
use crate::math::finite_probe;
use crate::math::Vec3;
#[cfg(feature = "ground")]
use crate::math::{add, axpy, dot, scale, sub};
use crate::rigid::Rigid;
#[cfg(feature = "probe")]
use crate::storage::BOUNDARY;
#[cfg(feature = "friction")]
use crate::storage::STUCK;
use crate::storage::{Node, NodeWork};
#[cfg(feature = "ground")]
use crate::storage::{CONTACT, FIXED, ON_GROUND, RELEASED};
#[cfg(feature = "ground")]
use ground::{Contact, Plane};
#[cfg(feature = "ground")]
pub(crate) use impact::impact;
#[cfg(feature = "ground")]
use lift::Lift;
#[cfg(feature = "ground")]
use plane_fit::PlaneFit;
#[cfg(feature = "ground")]
pub(crate) use relax::relax;

/// The probes a step presses on the body with (nothing without `probe`).
pub(crate) struct Probes<'a> {
    #[cfg(feature = "probe")]
    pub(crate) list: &'a mut [crate::Probe],
    pub(crate) _life: core::marker::PhantomData<&'a mut ()>,
}

/// The ground and its friction (nothing without the feature `ground`), and
/// the step's length.
#[derive(Clone, Copy)]
pub(crate) struct Ground {
    #[cfg(feature = "ground")]
    pub(crate) plane: Option<Plane>,
    #[cfg(feature = "friction")]
    pub(crate) friction: crate::Friction,
    #[cfg(feature = "ground")]
    pub(crate) h: f32,
    /// `|g| h`, the speed gravity gives in a step ([`HoldOn`]).
    #[cfg(feature = "ground")]
    pub(crate) settle: f32,
}

/// What can hold a node during a step: the ground and the probes.
#[derive(Clone, Copy)]
pub(crate) struct Obstacles<'a> {
    #[cfg(feature = "ground")]
    ground: Option<Plane>,
    #[cfg(feature = "friction")]
    ground_friction: crate::Friction,
    /// [`Ground::settle`].
    #[cfg(feature = "ground")]
    settle: f32,
    #[cfg(feature = "probe")]
    probes: &'a [crate::Probe],
    _life: core::marker::PhantomData<&'a ()>,
}

impl<'a> Obstacles<'a> {
    /// The scene's ground and the step's probes.
    #[inline(always)]
    pub(crate) fn new(ground: Ground, probes: &'a Probes<'_>) -> Self {
        let _ = (ground, probes);
        Self {
            #[cfg(feature = "ground")]
            ground: ground.plane,
            #[cfg(feature = "friction")]
            ground_friction: ground.friction,
            #[cfg(feature = "ground")]
            settle: ground.settle,
            #[cfg(feature = "probe")]
            probes: probes.list,
            _life: core::marker::PhantomData,
        }
    }

    /// Whether anything can hold a node: the ground or a probe.
    #[cfg(feature = "ground")]
    #[inline(always)]
    pub(crate) fn any(&self) -> bool {
        #[cfg(feature = "probe")]
        if !self.probes.is_empty() {
            return true;
        }
        self.ground.is_some()
    }

    /// The filter `S` of node `i`: the normal of its contact plane removed
    /// from a held node. The obstacles are tested first: without them, the
    /// loop reads no node flags.
    #[inline(always)]
    pub(crate) fn filter(&self, nodes: &[Node], i: usize, z: Vec3) -> Vec3 {
        #[cfg(feature = "ground")]
        if self.any() {
            if let Some(n) = nodes.get(i) {
                // A sticking node's velocity is prescribed whole.
                #[cfg(feature = "friction")]
                if n.flags & STUCK != 0 {
                    return [0.0; 3];
                }
                if let Some(c) = self.holding(n) {
                    return c.filter(z);
                }
            }
        }
        let _ = (i, nodes);
        z
    }

    /// A sliding node's kinetic friction, along its contact plane, added to
    /// the force `f` of the right-hand side.
    #[inline(always)]
    pub(crate) fn drag(&self, n: &Node, w: &mut NodeWork, f: Vec3) -> Vec3 {
        #[cfg(feature = "friction")]
        if w.drag != [0.0; 3] {
            if let Some(c) = self.holding(n) {
                w.drag = c.filter(w.drag);
                return add(f, w.drag);
            }
        }
        let _ = (n, w);
        f
    }
}

#[cfg(feature = "ground")]
impl Obstacles<'_> {
    /// The ground's plane, with its friction.
    #[inline(always)]
    fn ground_contact(&self, g: Plane) -> Contact {
        #[cfg(feature = "friction")]
        return Contact {
            friction: self.ground_friction,
            ..Contact::still(g)
        };
        #[cfg(not(feature = "friction"))]
        Contact::still(g)
    }

    /// The contact plane of a node the step holds (`CONTACT`): the ground's,
    /// or its probe's, recomputed from the same positions and poses as when
    /// the node was found (so with the same bits).
    #[inline(always)]
    pub(crate) fn holding(&self, n: &Node) -> Option<Contact> {
        if n.flags & CONTACT == 0 {
            return None;
        }
        if n.contact == ON_GROUND {
            return self.ground.map(|g| self.ground_contact(g));
        }
        #[cfg(feature = "probe")]
        if let Some(p) = self.probes.get(usize::from(n.contact) - 1) {
            return Some(p.contact(n.position()));
        }
        None
    }

    /// The obstacle that holds a free node at `x` this step, and its plane:
    /// the ground if the node touches or is below it and is not moving
    /// away; a probe (for a node on the boundary) if the probe reaches it
    /// during the step and it is not moving away faster than the probe.
    /// Of several, the one the node ends deepest in. A node held last step
    /// (`was`) is held by a probe while it is within
    /// [`Probe::gap`](crate::Probe) of its surface (where the last step left
    /// it, up to rounding and the probe's own turn), however the node moves:
    /// a node pressed by a moving probe moves with it, as fast as its plane
    /// up to rounding, and one pressed against a still probe stays on it;
    /// the contact force decides release. Whichever obstacle held it: a node
    /// touching the probe is held, and a caller that takes a probe out of
    /// the slice renumbers the ones after it.
    #[inline(always)]
    fn deepest(
        &self,
        n: &Node,
        x: Vec3,
        h: f32,
        was: Option<u16>,
        on: HoldOn,
    ) -> Option<(u16, Contact)> {
        let mut best: Option<(u16, Contact, f32)> = None;
        if let Some(g) = self.ground {
            let c = self.ground_contact(g);
            let dist = c.distance(x);
            if c.holds(dist - on.gap, axpy(n.v, -on.speed, c.normal), h) {
                best = Some((ON_GROUND, c, dist));
            }
        }
        #[cfg(feature = "probe")]
        if n.flags & BOUNDARY != 0 {
            // At most `MAX_PROBES`, checked by `step_with_probes`: the id
            // fits.
            for (k, p) in self.probes.iter().enumerate() {
                let c = p.contact(x);
                let dist = c.distance(x);
                let id = k as u16 + 1;
                let holds = c.holds(dist, n.v, h) || (was.is_some() && dist <= p.gap(x, n.v, h));
                if holds && best.is_none_or(|b| dist < b.2) {
                    best = Some((id, c, dist));
                }
            }
        }
        let _ = was; // only probes hold on by it
        best.map(|(id, c, _)| (id, c))
    }
}

/// Whether the ground holds `n` this step.
#[cfg(feature = "ground")]
#[inline(always)]
pub(crate) fn on_ground(n: &Node) -> bool {
    n.flags & CONTACT != 0 && n.contact == ON_GROUND
}

/// How far off the ground's plane (`gap`), and how fast away from it
/// (`speed`), a node that the ground held last step, and did not let go
/// for pulling, may start a step and still be held; zero for every other
/// node.
///
/// Such a node ends its step on the plane only up to the rounding of its
/// position (a landing's rigid impact recomputes every position about the
/// centre of mass: 4 ε times its magnitudes), or off it: the rigid impact
/// of another node's landing gives it an outward speed, a push out leaves
/// it above. Let go for that, it falls for a step (without friction, if it
/// had any), lands, is pushed out and lifts off again: a contact every
/// other step. With friction, Coulomb's law then holds in none of those
/// steps (the 10 × 10 × 5 cm block at μ 0.5 slid 80 % of Coulomb's
/// distance, its support up to 2.4 times the cone); without, each landing
/// and push works on the body (a spinning liver of slivers gained kinetic
/// energy on the ground and ended with an inverted element). Held on, the
/// step takes its outward speed back and brings it to the plane, and the
/// solve's force decides its release, as for every held node. The speed
/// is at most what its last contact impulse `λₙ = −pull` gives its mass,
/// so that the contact's impulse stays a push while the forces that
/// pressed it press again, and at most what gravity gives in a step
/// (`settle`, `|g| h`), so that it is no faster than a fall; the gap is
/// what that speed covers in the step. For a stiff body `settle` is
/// smaller (the detect stage, `step::guess::detect`), so that bringing the
/// node back strains the body no more than its weight does.
#[cfg(feature = "ground")]
#[derive(Clone, Copy, Default)]
struct HoldOn {
    gap: f32,
    speed: f32,
}

#[cfg(feature = "ground")]
impl HoldOn {
    #[inline(always)]
    fn new(
        obstacles: &Obstacles<'_>,
        n: &Node,
        w: &NodeWork,
        x: Vec3,
        h: f32,
        was: Option<u16>,
    ) -> Self {
        if let (Some(ON_GROUND), Some(g)) = (was, obstacles.ground) {
            let speed = (-w.pull / n.mass).min(obstacles.settle);
            let speed = if speed > 0.0 && speed.is_finite() {
                speed
            } else {
                0.0
            };
            return Self {
                gap: g.rounding(x) + h * speed,
                speed,
            };
        }
        Self::default()
    }
}

/// The nodes the obstacles hold this step.
#[derive(Clone, Copy, Default)]
pub(crate) struct Held {
    /// Nodes held (by the ground or a probe).
    pub(crate) held: u32,
    /// Held nodes below their plane beyond round-off, which the step
    /// pushes out.
    pub(crate) pushes: u32,
    /// The nodes the ground holds (the others' are probes').
    #[cfg_attr(not(feature = "ground"), allow(dead_code))]
    pub(crate) ground: u32,
}

impl Held {
    /// Whether the step pushes held nodes out of their obstacle (and then
    /// relaxes the push out of the velocity).
    #[inline(always)]
    pub(crate) fn relaxed(&self) -> bool {
        cfg!(feature = "ground") && self.pushes > 0
    }
}

/// The detect stage: zeroes the probes' sums, and marks each node that an
/// obstacle holds this step (`CONTACT`, what holds it in `Node::contact`),
/// and, with friction, whether it sticks (`STUCK`) or slides on with the
/// drag the last step planned.
#[inline(always)]
pub(crate) fn detect(
    obstacles: Obstacles<'_>,
    nodes: &mut [Node],
    work: &mut [NodeWork],
    h: f32,
) -> Held {
    #[allow(unused_mut)] // only the ground counts held nodes
    let mut held = Held::default();
    #[cfg(feature = "ground")]
    if obstacles.any() {
        for (n, _w) in nodes.iter_mut().zip(work.iter_mut()) {
            // What held the node last step (not released, or it is skipped).
            let was = (n.flags & CONTACT != 0).then_some(n.contact);
            n.flags &= !CONTACT;
            // Between steps the flag says the node slid on `was` in the
            // last step and did not stop; within a step, it sticks.
            #[cfg(feature = "friction")]
            let slid = n.flags & STUCK != 0;
            #[cfg(feature = "friction")]
            {
                n.flags &= !STUCK;
            }
            // The planned drag, kept below only for a node that slides on.
            #[cfg(feature = "friction")]
            let drag = core::mem::replace(&mut _w.drag, [0.0; 3]);
            if n.flags & (FIXED | RELEASED) != 0 {
                continue;
            }
            let x = n.position();
            let on = HoldOn::new(&obstacles, n, _w, x, h, was);
            if let Some((id, c)) = obstacles.deepest(n, x, h, was, on) {
                n.flags |= CONTACT;
                n.contact = id;
                // A held node sticks unless it slid on the same obstacle
                // in the last step (and did not stop): a contact that the
                // static friction cannot hold is found by its impulse
                // (`Contact::drag_after_stick`), and slides from the next
                // step, with the kinetic friction force planned then.
                #[cfg(feature = "friction")]
                if slid && was == Some(id) {
                    _w.drag = drag;
                } else if c.friction.sticks() {
                    n.flags |= STUCK;
                }
                held.held += 1;
                held.ground += u32::from(id == ON_GROUND);
                held.pushes += u32::from(c.push(x).is_some());
            }
        }
    } else {
        // No node is held (flags left by an earlier step).
        clear(nodes);
    }
    let _ = (obstacles, nodes, work, h);
    held
}

/// Whether the ground's contact may be the whole body's
/// ([`whole::solve`]): a ground, no probe, no fixed node, no `tool`
/// holding the body, and a node the ground held last step or that a
/// step's fall from its velocity takes to the plane.
#[cfg(feature = "ground")]
#[inline(always)]
pub(crate) fn whole_candidate(
    ground: Ground,
    probes: &Probes<'_>,
    tool: bool,
    any_fixed: bool,
    nodes: &[Node],
) -> bool {
    let Some(g) = ground.plane else {
        return false;
    };
    #[cfg(feature = "probe")]
    if !probes.list.is_empty() {
        return false;
    }
    let _ = probes;
    if any_fixed || tool {
        return false;
    }
    let c = Contact::still(g);
    let h = ground.h;
    nodes.iter().any(|n| {
        let reach = c.distance(n.position()) + h * dot(c.normal, n.v).min(0.0) - h * ground.settle;
        on_ground(n) || reach <= 0.0
    })
}

/// Clears every node's contact flags: nothing holds a node this step.
#[cfg(feature = "ground")]
#[inline(always)]
pub(crate) fn clear(nodes: &mut [Node]) {
    for n in nodes.iter_mut() {
        n.flags &= !CONTACT;
        #[cfg(feature = "friction")]
        {
            n.flags &= !STUCK;
        }
    }
}

/// The ground's rigid helpers for a body that the ground holds and no
/// fixed node does (nothing without the feature `ground`).
#[derive(Clone, Copy, Default)]
pub(crate) struct Carry {
    /// The body at the step's start, with its inertia.
    #[cfg(feature = "ground")]
    resting: Option<Rigid>,
    /// The rigid push out of the ground, for a body it alone holds.
    #[cfg(feature = "ground")]
    lift: Option<Lift>,
    /// The plane's rigid motion that the guess starts from.
    #[cfg(feature = "ground")]
    carried: Option<(PlaneFit, (f32, Vec3))>,
}

/// The carry stage, for a body that the ground holds and no fixed node
/// does.
///
/// * **The guess.** The guess's rigid part is the plane's motion that gives
///   the held nodes their prescribed normal velocity change (`PlaneFit`),
///   not the free fall `fall`. A resting body then starts at rest, carried
///   as a whole, and the solve has only its deformation to find: the part
///   a truncated solve resolves. (From the free fall it would have to stop
///   the whole body through the layer above the held nodes.)
/// * **The push.** Nodes the ground pushes out, of a body it alone holds
///   and that moves as one over the step ([`crate::rigid::share`]): the
///   push is the rigid lift that takes every held node at least to the
///   plane (`Lift`), not each node to the plane on its own.
///
/// (The body's inertia at the step's start serves the landing too: the
/// nodes do not move until the step is applied.)
#[inline(always)]
pub(crate) fn carry(
    ground: Ground,
    held: &Held,
    any_fixed: bool,
    fall: Vec3,
    start: Option<Rigid>,
    nodes: &[Node],
    reach: impl FnOnce(&Rigid) -> f32,
) -> Carry {
    let _ = (ground, held, any_fixed, fall, start, nodes, &reach);
    #[cfg(feature = "ground")]
    {
        let h = ground.h;
        let ground = ground.plane;
        let resting = match ground {
            Some(_) if held.ground > 0 && !any_fixed => start.or_else(|| Rigid::new(nodes, true)),
            _ => None,
        };
        let lift = match (ground, &resting) {
            (Some(g), Some(body))
                if held.pushes > 0 && held.held == held.ground && reach(body) >= 1.0 =>
            {
                Lift::new(g, body, nodes, h)
            }
            _ => None,
        };
        let mut carry = Carry {
            resting,
            lift,
            carried: None,
        };
        carry.carried = match (ground, &resting) {
            (Some(g), Some(body)) => {
                let mut fit = PlaneFit::new(g.normal, body.c);
                let g = Contact::still(g);
                for n in nodes.iter().filter(|n| on_ground(n)) {
                    let dv = g.held_dv(carry.depth(n, g.distance(n.position()), h), n.v, h);
                    fit.add(n.position(), n.mass, dv - dot(g.normal, fall));
                }
                fit.solve(body).map(|m| (fit, m))
            }
            _ => None,
        };
        carry
    }
    #[cfg(not(feature = "ground"))]
    Carry::default()
}

impl Carry {
    /// The depth below its plane, at `dist`, that the push of node `n` takes
    /// out: the lift's where there is one.
    #[cfg(feature = "ground")]
    #[inline(always)]
    fn depth(&self, n: &Node, dist: f32, h: f32) -> f32 {
        self.lift.as_ref().map_or(dist, |l| l.depth(n, dist, h))
    }

    /// The rigid lift, for a body the ground alone holds.
    #[cfg(feature = "ground")]
    #[inline(always)]
    pub(crate) fn lift(&self) -> Option<&Lift> {
        self.lift.as_ref()
    }

    /// The body at the step's start, when the ground holds it.
    #[cfg(feature = "ground")]
    #[inline(always)]
    pub(crate) fn resting(&self) -> Option<Rigid> {
        self.resting
    }

    /// A free node's guess `x`, with the carried body's rigid motion added
    /// and a held node's prescribed normal (or, sticking, whole) velocity
    /// change.
    #[inline(always)]
    pub(crate) fn guess(&self, obstacles: Obstacles<'_>, n: &Node, x: Vec3, h: f32) -> Vec3 {
        #[cfg(feature = "ground")]
        {
            let mut x = x;
            if let Some((fit, m)) = &self.carried {
                x = add(x, fit.at(n.position(), *m));
            }
            if let Some(c) = obstacles.holding(n) {
                let dist = self.depth(n, c.distance(n.position()), h);
                x = c.with_normal(x, c.held_dv(dist, n.v, h));
                #[cfg(feature = "friction")]
                if n.flags & STUCK != 0 {
                    x = c.stuck_dv(dist, n.v, h);
                }
            }
            x
        }
        #[cfg(not(feature = "ground"))]
        {
            let _ = (obstacles, n, h);
            x
        }
    }
}

/// The end of the step's position update for node `n` with its new
/// velocity `v`: after `relax`, positions move with the velocity change
/// before it (`dv`), the push out included.
#[inline(always)]
pub(crate) fn displaced(n: &Node, w: &NodeWork, v: Vec3, relaxed: bool, h: f32) -> Vec3 {
    #[cfg(feature = "ground")]
    return axpy(n.u, h, if relaxed { add(n.v, w.dv) } else { v });
    #[cfg(not(feature = "ground"))]
    {
        let _ = (w, relaxed);
        crate::math::axpy(n.u, h, v)
    }
}

/// Whether a node that the ground does not hold ends at displacement `u`
/// below it (held nodes end on the plane, below it by round-off at most,
/// which the next step holds again: only the others can land).
#[inline(always)]
pub(crate) fn lands(ground: Ground, n: &Node, u: Vec3) -> bool {
    let _ = (ground, n, u);
    #[cfg(feature = "ground")]
    if let Some(g) = ground.plane {
        return !on_ground(n) && Contact::still(g).distance(add(n.x0, u)) < 0.0;
    }
    false
}

/// Whether any node ends below the ground (end displacements in
/// [`NodeWork::end`]).
#[cfg(feature = "free-rotation")]
#[inline(always)]
pub(crate) fn below(ground: Ground, nodes: &[Node], work: &[NodeWork]) -> bool {
    let _ = (ground, nodes, work);
    #[cfg(feature = "ground")]
    if let Some(g) = ground.plane {
        return nodes
            .iter()
            .zip(work.iter())
            .any(|(n, w)| Contact::still(g).distance(add(n.x0, w.end().0)) < 0.0);
    }
    false
}

/// A node's landing at the step's end (displacement `u`, velocity `v`):
/// below the ground, it loses its inward normal velocity (`Plane::stop`)
/// and is pushed out by the next step; inside a probe, the same relative to
/// the probe's own, which feels the impulse. Adds the ground's impulse to
/// `support`; returns the velocity and whether a probe stopped the node.
#[inline(always)]
pub(crate) fn land(
    ground: Ground,
    probes: &mut Probes<'_>,
    n: &Node,
    u: Vec3,
    v: Vec3,
    support: &mut Vec3,
) -> (Vec3, bool) {
    let _ = (ground, &probes, n, u, &support);
    #[allow(unused_mut)] // only probes land nodes in them
    let mut landed = false;
    #[cfg(feature = "ground")]
    let h = ground.h;
    #[cfg(feature = "ground")]
    let v = match ground.plane {
        Some(g) => {
            let c = Contact::still(g);
            let stopped = c.stop(add(n.x0, u), v, h);
            #[cfg(feature = "friction")]
            let stopped = landing_friction(&c, ground.friction, v, stopped);
            *support = axpy(*support, n.mass, sub(stopped, v));
            stopped
        }
        None => v,
    };
    #[cfg(feature = "probe")]
    let v = if !probes.list.is_empty() && n.flags & BOUNDARY != 0 {
        let x = add(n.x0, u);
        let mut v = v;
        for p in probes.list.iter_mut() {
            if let Some(c) = p.inside(x) {
                let stopped = c.stop(x, v, h);
                p.next_force = axpy(p.next_force, -n.mass, sub(stopped, v));
                landed = true;
                v = stopped;
            }
        }
        v
    } else {
        v
    };
    (v, landed)
}

/// The momentum `p` that the contacts' impulses at the cone leave the body
/// with ([`impulse`]), given to its free nodes as one velocity `p / M`, so
/// that the body's momentum changes by the impulses the step reports; the
/// displacements move by it over the step. Folds the new state into the
/// finite `probe` (`math::finite_probe`).
#[cfg(feature = "friction")]
#[inline(always)]
pub(crate) fn spread(p: Vec3, h: f32, nodes: &[Node], work: &mut [NodeWork], probe: f32) -> f32 {
    let mass: f32 = nodes
        .iter()
        .filter(|n| n.flags & FIXED == 0)
        .map(|n| n.mass)
        .sum();
    if !(mass > 0.0) {
        return probe;
    }
    let dv = scale(p, 1.0 / mass);
    let mut probe = probe;
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        if n.flags & FIXED != 0 {
            continue;
        }
        let (u, v) = w.end();
        let (u, v) = (axpy(u, h, dv), add(v, dv));
        probe = finite_probe(finite_probe(probe, add(n.x0, u)), v);
        w.set_end(u, v);
    }
    probe
}

/// The friction of a landing on the ground (`land`): the node stopped along
/// the normal, from `v` to `stopped`, by the impulse `m Δvₙ`, also loses
/// its velocity along the plane up to `μ Δvₙ` (per unit mass): all of it,
/// within the static cone (it sticks), or `μk Δvₙ` of it.
#[cfg(feature = "friction")]
#[inline(always)]
fn landing_friction(c: &Contact, friction: crate::Friction, v: Vec3, stopped: Vec3) -> Vec3 {
    let press = dot(c.normal, sub(stopped, v));
    if !(press > 0.0) {
        return stopped;
    }
    let slip = c.filter(stopped);
    let size2 = dot(slip, slip);
    let stick = friction.static_coefficient() * press;
    if size2 <= stick * stick {
        return sub(stopped, slip);
    }
    let slide = friction.kinetic_coefficient() * press;
    axpy(stopped, -slide / crate::math::sqrt(size2), slip)
}

/// A held node's contact impulse at the step's end (displacement `u`,
/// velocity `v`), and its friction, which moves its velocity and position.
/// Adds the ground's impulse to `support` and a probe's to the probe, and
/// to `spread` the momentum that Coulomb's law at the step's end leaves
/// the body with ([`spread`]).
///
/// The constraint impulses are `−r` from the step's solve. After `relax`
/// (which kept the step's `n·r` of held nodes in `pull`), `r` is the push's
/// residual `r_w`: the velocity change kept, `dv − w`, has the residual of
/// the step's less the push's (`A (dv − w) = b − r_dv + r_w`), so its
/// impulses are the step's less the push's, which only moved positions.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn impulse(
    ground: Ground,
    probes: &mut Probes<'_>,
    n: &Node,
    w: &mut NodeWork,
    (u, v): (Vec3, Vec3),
    relaxed: bool,
    support: &mut Vec3,
    spread: &mut Vec3,
) -> (Vec3, Vec3) {
    let _ = (ground, &probes, n, &w, relaxed, &support, &spread);
    #[cfg(feature = "ground")]
    {
        #[allow(unused_mut)] // only friction moves them
        let (mut u, mut v) = (u, v);
        let holding = Obstacles::new(ground, probes).holding(n);
        if let Some(c) = holding {
            // `pull` (the step's solve's, with the push) decides the
            // release; the impulse is that of the velocity kept.
            let along = dot(c.normal, w.r);
            let kept = if relaxed { w.pull - along } else { along };
            if !relaxed {
                w.pull = along;
            }
            #[allow(unused_mut)] // only friction adds to it
            let mut impulse = scale(c.normal, -kept);
            #[cfg(feature = "friction")]
            {
                let (dv, whole);
                (impulse, dv, whole) = friction(&c, n, w, impulse, v, kept, relaxed, ground.h);
                v = add(v, dv);
                u = axpy(u, ground.h, dv);
                *spread = add(*spread, whole);
            }
            if n.contact == ON_GROUND {
                *support = add(*support, impulse);
            }
            #[cfg(feature = "probe")]
            if let Some(p) = usize::from(n.contact)
                .checked_sub(1)
                .and_then(|k| probes.list.get_mut(k))
            {
                p.next_force = sub(p.next_force, impulse);
                p.next_contacts += 1;
                // A node its contact still pushes (it stays held) ends on
                // the curved surface, not outside it on the tangent plane:
                // else the next step would find it off the probe and let it
                // go for a step, in which the body's push drives it deep
                // inside (a contact that flickers).
                if w.pull <= 0.0 {
                    if let Some(off) = p.outside(add(n.x0, u)) {
                        u = sub(u, off);
                    }
                }
            }
        }
        (u, v)
    }
    #[cfg(not(feature = "ground"))]
    (u, v)
}

/// Friction at a held node with the normal impulse `impulse` (`kept` along
/// the normal) and end velocity `v`: the whole impulse made Coulomb's
/// ([`within_cone`]), the node's own velocity change, the momentum left to
/// the body as a whole, and the next step's friction planned in
/// `reaction`. A sticking node's tangential impulse is its residual's;
/// beyond the static cone (where the cone stage's rounds ran out) it
/// slides from the next step, with the kinetic force along it. A sliding
/// node's is its kinetic force's (in the solve's right-hand side); it
/// slides on against its slip, or, turned back by its friction, sticks
/// from the next step.
#[cfg(feature = "friction")]
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn friction(
    c: &Contact,
    n: &Node,
    w: &mut NodeWork,
    impulse: Vec3,
    v: Vec3,
    kept: f32,
    relaxed: bool,
    h: f32,
) -> (Vec3, Vec3, Vec3) {
    let press = -kept;
    let (tangential, next) = if n.flags & STUCK != 0 {
        let r = if relaxed { sub(w.reaction, w.r) } else { w.r };
        let held = c.filter(scale(r, -1.0));
        (held, c.drag_after_stick(add(impulse, held), h))
    } else if w.drag != [0.0; 3] {
        let slip = c.sliding(v, h);
        let next = if turned_back(n, slip, w.drag, h) {
            [0.0; 3]
        } else if dot(slip, w.drag) < 0.0 {
            c.drag(scale(slip, -1.0), press, h)
        } else {
            c.drag(w.drag, press, h)
        };
        (scale(w.drag, h), next)
    } else {
        ([0.0; 3], [0.0; 3])
    };
    w.reaction = next;
    let (tangential, dv, whole) = within_cone(c, n, tangential, press, v, h);
    // A ground contact with friction that pulls lets go within the step:
    // the body keeps the pull it no longer gets. Only there does a cone
    // depend on it; a probe's or a frictionless ground's pulling contact
    // lets go from the next step (`commit`).
    if press < 0.0 && n.contact == ON_GROUND && c.friction.sticks() {
        let pull = scale(c.normal, press);
        return (add(sub(impulse, pull), tangential), dv, sub(whole, pull));
    }
    (add(impulse, tangential), dv, whole)
}

/// A held node's tangential impulse `t` made Coulomb's at its normal
/// impulse `press` and its end slip (relative to the obstacle, from its
/// end velocity `v` over the step `h`), and what that changes:
/// `(t', Δv, Δp)`.
///
/// * A sticking node's within `μs press` is kept.
/// * A sliding node's below `μk press` grows against the slip, up to
///   `μk press` or until the slip stops: the node's velocity changes by
///   `Δv = (t' − t) / m`, which takes no more than its slip.
/// * One beyond the cone (`μs` for a sticking node, `μk` for a sliding one;
///   none where the contact pulls) is cut to `μk press`: the body keeps the
///   momentum cut, `Δp = t' − t`, which the caller spreads over it as a
///   whole. (On the node alone, as `Δp / m`, it measured to overshoot: a
///   soft, nearly incompressible bunny landing with friction gained energy
///   until the step diverged.)
///
/// The rounds decide sticking and sliding inside the solve, with a sliding
/// node's force from an earlier round's normal impulse; where they run
/// out, the step still ends on Coulomb's law, with the momentum of the
/// impulse it reports.
#[cfg(feature = "friction")]
#[inline(always)]
fn within_cone(c: &Contact, n: &Node, t: Vec3, press: f32, v: Vec3, h: f32) -> (Vec3, Vec3, Vec3) {
    let size2 = dot(t, t);
    let press = press.max(0.0);
    let stick = c.friction.static_coefficient() * press;
    if n.flags & STUCK != 0 && size2 <= stick * stick || !(n.mass > 0.0) {
        return (t, [0.0; 3], [0.0; 3]);
    }
    let bound = c.friction.kinetic_coefficient() * press;
    if size2 > bound * bound {
        let cut = scale(t, bound / crate::math::sqrt(size2));
        return (cut, [0.0; 3], sub(cut, t));
    }
    let room = bound - crate::math::sqrt(size2);
    let slip = c.sliding(v, h);
    let moving = crate::math::sqrt(dot(slip, slip)) * n.mass;
    if !(room > 0.0 && moving > 0.0) {
        return (t, [0.0; 3], [0.0; 3]);
    }
    let grown = scale(slip, -room.min(moving) / moving);
    (axpy(t, n.mass, grown), grown, [0.0; 3])
}

/// Whether a sliding node's friction force `drag` turned it back: its slip
/// `slip` (relative to the obstacle) is along the force, by more than the
/// rounding of its position over the step `h`. A slip within that rounding
/// is no motion: the node is on the point of slipping and slides on, at
/// the force of the cone's edge.
#[cfg(feature = "friction")]
#[inline(always)]
fn turned_back(n: &Node, slip: Vec3, drag: Vec3, h: f32) -> bool {
    if dot(slip, drag) < 0.0 {
        return false;
    }
    let x = n.position();
    let size = x[0].abs() + x[1].abs() + x[2].abs();
    h * crate::math::sqrt(dot(slip, slip)) > 4.0 * f32::EPSILON * size
}

/// What a round of the cone stage changed.
#[derive(Clone, Copy, Default)]
pub(crate) struct Round {
    /// Nodes whose friction state or force changed: the solve goes on.
    pub(crate) changed: u32,
    /// Nodes that stick again or are caught: their velocity change moved
    /// by `d`, whose `A d` the residual must lose before the solve goes on.
    pub(crate) moved: u32,
    /// Free nodes caught by the ground (`catch`).
    pub(crate) caught: u32,
}

/// The kinetic force of a sliding node is made that of the current normal
/// impulse when it moves by more than this fraction of itself. A
/// truncated solve's impulses move by more than that from round to round,
/// so the rounds run out first: the fraction only ends them early where
/// the solve has settled.
#[cfg(feature = "friction")]
const DRAG_TOLERANCE: f32 = 1e-2;

/// The cone stage: one round of the friction state of the held nodes,
/// decided by the impulses `λ = −r` of the solve just made (feature
/// `friction`; nothing without it):
///
/// * a sticking node whose impulse leaves the static cone
///   (`|λₜ| > μs λₙ`) slides, with the kinetic force `μk λₙ / h` along its
///   tangential impulse;
/// * a sliding node's force follows its current `λₙ`; one that its force
///   turned back (its slip `v + Δv`, relative to the obstacle, along the
///   force beyond rounding) sticks;
/// * a held node without friction yet (one that pulled in an earlier
///   round) slides against its slip;
/// * a node whose contact pulls (`λₙ < 0`) has no friction: a cone of
///   negative height holds nothing. (Whether it stays held is the
///   contact's rule after the solve.)
/// * with `catch`, a free node that the solve takes below a ground with
///   friction by the step's end is held from this round on ([`catchable`]).
///
/// Every change keeps `r = b − A x` exact: a force adds `h` times itself to
/// the residual, and a node that sticks again or is caught gets its
/// prescribed velocity change in `x` and the move in `d` (zero elsewhere),
/// for the caller to take `A d` off `r`. The solve then goes on from the
/// iterate it stopped at, with the new state.
#[inline(always)]
pub(crate) fn cone(
    obstacles: Obstacles<'_>,
    nodes: &mut [Node],
    work: &mut [NodeWork],
    h: f32,
    catch: bool,
) -> Round {
    let _ = (obstacles, &nodes, &work, h, catch);
    #[allow(unused_mut)] // only friction changes the state
    let mut round = Round::default();
    #[cfg(feature = "friction")]
    if obstacles.any() {
        // The ground, where it has friction, for the catch.
        let ground = obstacles
            .ground
            .map(|g| obstacles.ground_contact(g))
            .filter(|c| catch && c.friction.sticks());
        for (n, w) in nodes.iter_mut().zip(work.iter_mut()) {
            w.d = [0.0; 3];
            let Some(c) = obstacles.holding(n) else {
                if let Some(g) = &ground {
                    if let Some(start) = catchable(g, n, w, h) {
                        catch_at(g, n, w, start, h);
                        round.changed += 1;
                        round.moved += 1;
                        round.caught += 1;
                    }
                }
                continue;
            };
            match slide_or_stick(&c, n, w, scale(w.r, -1.0), h) {
                Change::None => {}
                Change::Force => round.changed += 1,
                Change::Moved => {
                    round.changed += 1;
                    round.moved += 1;
                }
            }
        }
    }
    round
}

/// Whether some free node would be caught by the ground with friction
/// (`catchable`): the rounds find the body's stiffness, a pass over the
/// elements, only then.
#[cfg(feature = "friction")]
#[inline(always)]
pub(crate) fn any_catchable(
    obstacles: Obstacles<'_>,
    nodes: &[Node],
    work: &[NodeWork],
    h: f32,
) -> bool {
    let Some(g) = obstacles.ground.map(|g| obstacles.ground_contact(g)) else {
        return false;
    };
    g.friction.sticks()
        && nodes
            .iter()
            .zip(work.iter())
            .any(|(n, w)| n.flags & CONTACT == 0 && catchable(&g, n, w, h).is_some())
}

/// The catch of a round (`cone`): a free node (not fixed, not held) that
/// starts the step on or above the ground's plane `g` and that the solve's
/// velocity change so far `x` takes below it by the step's end is held
/// from this round on, as the detect stage would hold it next step: its
/// normal velocity change prescribed so that it ends on the plane, and
/// sticking, unless the ground released it for pulling in the last step
/// (it slides then, from the next round). `catchable` gives a free node's
/// distance from the plane at the start if it is to be caught; `catch_at`
/// holds it.
///
/// Left for after the solve, such a node is stopped along the normal alone
/// (`land`): an impulse without friction. A soft block sliding past its
/// friction angle rocks on its front edge, its rear nodes land again and
/// again, and their landings carry much of its weight without the friction
/// of it: it slides faster than Coulomb's law allows (docs/contact.md).
#[cfg(feature = "friction")]
#[inline(always)]
fn catchable(g: &Contact, n: &Node, w: &NodeWork, h: f32) -> Option<f32> {
    if n.flags & FIXED != 0 {
        return None;
    }
    let x = n.position();
    let start = g.distance(x);
    (start >= 0.0 && g.distance(axpy(x, h, add(n.v, w.x))) < 0.0).then_some(start)
}

/// `catchable`'s node `n`, at distance `start`, held ([`catchable`]).
#[cfg(feature = "friction")]
#[inline(always)]
fn catch_at(g: &Contact, n: &mut Node, w: &mut NodeWork, start: f32, h: f32) {
    n.flags |= CONTACT;
    n.contact = ON_GROUND;
    let caught = if n.flags & RELEASED == 0 {
        n.flags |= STUCK;
        g.stuck_dv(start, n.v, h)
    } else {
        g.with_normal(w.x, g.held_dv(start, n.v, h))
    };
    w.d = sub(caught, w.x);
    w.x = caught;
}

/// What a round changed at one node.
#[cfg(feature = "friction")]
enum Change {
    None,
    /// Its friction force.
    Force,
    /// Its prescribed velocity change (by `d`).
    Moved,
}

/// The friction part of a round at a held node `n` with impulse `lambda`
/// (`cone`).
#[cfg(feature = "friction")]
#[inline(always)]
fn slide_or_stick(c: &Contact, n: &mut Node, w: &mut NodeWork, lambda: Vec3, h: f32) -> Change {
    let press = dot(c.normal, lambda);
    if !(press > 0.0) {
        // It pulls: no friction.
        if n.flags & STUCK != 0 {
            n.flags &= !STUCK;
            return Change::Force;
        }
        if w.drag != [0.0; 3] {
            w.r = axpy(w.r, -h, w.drag);
            w.drag = [0.0; 3];
            return Change::Force;
        }
        return Change::None;
    }
    if n.flags & STUCK != 0 {
        let drag = c.drag_after_stick(lambda, h);
        if drag == [0.0; 3] {
            return Change::None;
        }
        n.flags &= !STUCK;
        w.drag = drag;
        w.r = axpy(w.r, h, drag);
        return Change::Force;
    }
    let slip = c.sliding(add(n.v, w.x), h);
    if w.drag == [0.0; 3] {
        // Held without friction (its contact pulled in an earlier
        // round): it slides against its slip, and sticks if that turns
        // it back.
        let drag = c.drag(scale(slip, -1.0), press, h);
        if drag == [0.0; 3] {
            return Change::None;
        }
        w.drag = drag;
        w.r = axpy(w.r, h, drag);
        return Change::Force;
    }
    if turned_back(n, slip, w.drag, h) {
        // Turned back (or stopped): it sticks, its friction force gone,
        // its slip taken out of `x`.
        n.flags |= STUCK;
        w.r = axpy(w.r, -h, w.drag);
        w.drag = [0.0; 3];
        w.d = scale(slip, -1.0);
        w.x = add(w.x, w.d);
        return Change::Moved;
    }
    // Along the force it has: the slip's direction settles only with the
    // step (`friction` plans the next step's from it).
    let drag = c.drag(w.drag, press, h);
    let moved = sub(drag, w.drag);
    if dot(moved, moved) <= DRAG_TOLERANCE * DRAG_TOLERANCE * dot(drag, drag) {
        return Change::None;
    }
    w.r = axpy(w.r, h, moved);
    w.drag = drag;
    Change::Force
}

/// The commit of node `n`'s contact flags: a held node whose contact would
/// pull (`pull > 0`) is released for the next step; one that slides on
/// keeps the kinetic force planned.
#[inline(always)]
pub(crate) fn commit(n: &mut Node, w: &mut NodeWork) {
    let _ = (&n, &w);
    #[cfg(feature = "ground")]
    {
        n.flags &= !RELEASED;
        if n.flags & CONTACT != 0 && w.pull > 0.0 {
            n.flags |= RELEASED;
        }
        #[cfg(feature = "friction")]
        {
            n.flags &= !STUCK;
            w.drag = [0.0; 3];
            if n.flags & (CONTACT | RELEASED) == CONTACT && w.reaction != [0.0; 3] {
                n.flags |= STUCK;
                w.drag = w.reaction;
            }
        }
    }
}

/// The commit of node `n`'s contact flags after the whole body's contact
/// ([`whole::solve`]): a node that ends on the plane (where the step
/// `solved` it) is marked held, with `pull = −λₙ` (its impulse in `dv`),
/// so that the next step knows the body rests; nothing slides on.
#[cfg(feature = "ground")]
#[inline(always)]
pub(crate) fn commit_whole(n: &mut Node, w: &mut NodeWork, normal: Vec3, solved: bool) {
    n.flags &= !(RELEASED | CONTACT);
    w.pull = 0.0;
    if solved && whole::touching(w) {
        n.flags |= CONTACT;
        n.contact = ON_GROUND;
        w.pull = -dot(normal, w.dv);
    }
    #[cfg(feature = "friction")]
    {
        n.flags &= !STUCK;
        w.drag = [0.0; 3];
        w.reaction = [0.0; 3];
    }
}

/// The probes' forces and contacts made current, and their poses those
/// of the step's end.
#[inline(always)]
pub(crate) fn commit_probes(probes: &mut Probes<'_>, h: f32) {
    let _ = (&probes, h);
    #[cfg(feature = "probe")]
    for p in probes.list.iter_mut() {
        p.commit(h);
    }
}

/// Zeroes the probes' sums for the step.
#[inline(always)]
pub(crate) fn begin(probes: &mut Probes<'_>) {
    let _ = &probes;
    #[cfg(feature = "probe")]
    for p in probes.list.iter_mut() {
        p.next_force = [0.0; 3];
        p.next_contacts = 0;
    }
}

/// `probe` (`math::finite_probe`) of every probe's force.
#[inline(always)]
pub(crate) fn finite(probes: &Probes<'_>, probe: f32) -> f32 {
    let _ = probes;
    #[cfg(feature = "probe")]
    let probe = probes
        .list
        .iter()
        .fold(probe, |acc, p| crate::math::finite_probe(acc, p.next_force));
    probe
}
