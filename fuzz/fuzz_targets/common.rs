//! Helpers shared by the fuzz targets: turning bytes into the values a user
//! could pass, and the "unchanged" and "finite" checks.

#![allow(dead_code)] // each target uses a part

use arbitrary::{Result, Unstructured};
use corofem::{Material, Method, Plane, Preconditioner, Scene, Settings, Storage};

/// A finite f32 of any magnitude: small integers, scaled integers from 1e-40
/// to 1e38, or any finite bit pattern.
pub fn finite(u: &mut Unstructured) -> Result<f32> {
    Ok(match u.int_in_range(0u8..=3)? {
        0 => f32::from(u.arbitrary::<i8>()?) * 0.25,
        1 => {
            let m = f32::from(u.arbitrary::<i16>()?);
            let e = i32::from(u.int_in_range(-40i8..=38)?);
            let x = m * 10f32.powi(e);
            if x.is_finite() {
                x
            } else {
                f32::MAX
            }
        }
        2 => {
            let x = f32::from_bits(u.arbitrary::<u32>()?);
            if x.is_finite() {
                x
            } else {
                0.0
            }
        }
        _ => 0.0,
    })
}

/// Any f32 at all, NaN and infinities included (one time in eight).
pub fn any_f32(u: &mut Unstructured) -> Result<f32> {
    if u.ratio(1u8, 8)? {
        Ok(*u.choose(&[f32::NAN, f32::INFINITY, f32::NEG_INFINITY])?)
    } else {
        finite(u)
    }
}

pub fn finite3(u: &mut Unstructured) -> Result<[f32; 3]> {
    Ok([finite(u)?, finite(u)?, finite(u)?])
}

pub fn any3(u: &mut Unstructured) -> Result<[f32; 3]> {
    Ok([any_f32(u)?, any_f32(u)?, any_f32(u)?])
}

/// A positive magnitude `m · 10^e` for `e` in `[lo, hi]`.
pub fn magnitude(u: &mut Unstructured, lo: i8, hi: i8) -> Result<f32> {
    let m = 1.0 + f32::from(u.arbitrary::<u8>()?) / 32.0;
    let e = i32::from(u.int_in_range(lo..=hi)?);
    Ok((m * 10f32.powi(e)).min(f32::MAX))
}

pub fn material(u: &mut Unstructured) -> Result<Material> {
    let young = match u.int_in_range(0u8..=3)? {
        0 => 0.0,
        1 => any_f32(u)?,
        _ => magnitude(u, -3, 12)?,
    };
    let poisson = match u.int_in_range(0u8..=3)? {
        0 => any_f32(u)?,
        1 => 0.499_999_97,
        _ => f32::from(u.arbitrary::<u8>()?) / 256.0 * 0.5,
    };
    let density = match u.int_in_range(0u8..=3)? {
        0 => any_f32(u)?,
        _ => magnitude(u, -6, 6)?,
    };
    Ok(Material {
        young,
        poisson,
        density,
    })
}

/// Step settings, valid or not.
pub fn settings(u: &mut Unstructured) -> Result<Settings> {
    let method = *u.choose(Method::COMPILED)?;
    let dt = if u.ratio(1u8, 8)? {
        any_f32(u)?
    } else {
        magnitude(u, -7, 1)?
    };
    let cg_iterations = if u.ratio(1u8, 4)? {
        u.int_in_range(0u32..=500)?
    } else {
        u.int_in_range(1u32..=10)?
    };
    let damping = |u: &mut Unstructured| -> Result<f32> {
        Ok(match u.int_in_range(0u8..=3)? {
            0 => any_f32(u)?,
            1 => magnitude(u, -6, 6)?,
            _ => 0.0,
        })
    };
    let cg_tolerance = damping(u)?;
    let rayleigh_mass = damping(u)?;
    let rayleigh_stiffness = damping(u)?;
    let warm_start = u.arbitrary()?;
    let preconditioner = *u.choose(&Preconditioner::VARIANTS)?;
    let gravity = if u.arbitrary()? {
        [0.0, 0.0, -9.81]
    } else {
        any3(u)?
    };
    let energy_guard = u.arbitrary()?;
    let free_rotation = u.arbitrary()?;
    let contact_rounds = u32::from(u.int_in_range(0u8..=8)?);
    let friction_damping = if u.arbitrary()? {
        damping(u)?
    } else {
        Settings::new().friction_damping
    };
    Ok(Settings {
        method,
        dt,
        cg_iterations,
        cg_tolerance,
        rayleigh_mass,
        rayleigh_stiffness,
        warm_start,
        preconditioner,
        gravity,
        energy_guard,
        free_rotation,
        contact_rounds,
        friction_damping,
    })
}

pub fn plane(u: &mut Unstructured) -> Result<Plane> {
    Ok(Plane {
        normal: any3(u)?,
        offset: any_f32(u)?,
    })
}

/// Everything observable about a scene, for "unchanged" checks.
#[derive(Debug, PartialEq)]
pub struct Fingerprint {
    hash: u64,
    counts: (usize, usize),
    settings: Settings,
    time: u64,
    fixed: Vec<bool>,
    rest: Vec<[u32; 3]>,
    masses: Vec<u32>,
    young: Vec<u32>,
    elements: Vec<Option<[u32; 4]>>,
    ground: Option<Plane>,
    tool: (bool, [u32; 3]),
}

pub fn fingerprint<S: Storage>(s: &Scene<S>) -> Fingerprint {
    let n = s.node_count();
    let e = s.element_count();
    let bits = |v: [f32; 3]| v.map(f32::to_bits);
    Fingerprint {
        hash: s.state_hash(),
        counts: (n, e),
        settings: *s.settings(),
        time: s.time().to_bits(),
        fixed: (0..n as u32).map(|i| s.is_fixed(i)).collect(),
        rest: (0..n as u32)
            .map(|i| bits(s.rest_position(i).unwrap()))
            .collect(),
        masses: (0..n as u32)
            .map(|i| s.mass(i).unwrap().to_bits())
            .collect(),
        young: (0..e).map(|i| s.young(i).unwrap().to_bits()).collect(),
        elements: (0..e).map(|i| s.element_nodes(i)).collect(),
        ground: s.ground(),
        tool: (s.is_grabbing(), bits(s.tool_target())),
    }
}

pub fn all_finite<S: Storage>(s: &Scene<S>) -> bool {
    s.positions()
        .chain(s.velocities())
        .all(|v| v.iter().all(|x| x.is_finite()))
}

/// Whether two scenes behave identically from now on (two default steps).
pub fn same_future<S: Storage + Clone>(a: &Scene<S>, b: &Scene<S>) -> bool {
    let (mut a, mut b) = (a.clone(), b.clone());
    (0..2).all(|_| {
        let (ra, rb) = (a.step(), b.step());
        ra == rb && a.state_hash() == b.state_hash()
    })
}
