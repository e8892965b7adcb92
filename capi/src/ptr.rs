//! Checked access to the caller's arrays and out-parameters.
//!
//! Every pointer from C goes through here: null, alignment, a length whose
//! byte size fits in `isize`, and no overlap with the scene buffer are
//! checked before a slice is formed. What cannot be checked (that the memory
//! exists and is not used concurrently) is the caller's contract.

use core::mem::{align_of, size_of};

use crate::arena::SceneHandle;
use crate::status::Status;

/// Types every bit pattern of which is a valid value (no `bool`, no enum), so
/// reading them from C memory can never produce an invalid value.
///
/// # Safety
///
/// Implement only for such types.
pub unsafe trait Plain: Copy {}
// SAFETY: integers and floats accept every bit pattern.
unsafe impl Plain for f32 {}
// SAFETY: as above.
unsafe impl Plain for u32 {}
// SAFETY: as above.
unsafe impl Plain for u64 {}
// SAFETY: as above.
unsafe impl Plain for usize {}
// SAFETY: as above.
unsafe impl Plain for f64 {}
// SAFETY: a raw pointer is an address; every bit pattern is one (handles
// written out are only ever read back as addresses, and checked).
unsafe impl<T> Plain for *mut T {}
// SAFETY: an array of a `Plain` type.
unsafe impl<T: Plain, const N: usize> Plain for [T; N] {}

fn check<T>(addr: usize, len: usize, guard: Option<&SceneHandle>) -> Result<(), Status> {
    if addr == 0 {
        return Err(Status::NullPointer);
    }
    if addr % align_of::<T>() != 0 {
        return Err(Status::Misaligned);
    }
    match len.checked_mul(size_of::<T>()) {
        Some(bytes) if bytes <= isize::MAX as usize => {}
        _ => return Err(Status::Capacity),
    }
    if guard.is_some_and(|g| g.overlaps::<T>(addr, len)) {
        return Err(Status::Overlap);
    }
    Ok(())
}

/// The byte range of `len` values of `T` at `ptr`, for [`disjoint`].
pub fn span<T>(ptr: *const T, len: usize) -> (usize, usize) {
    (ptr as usize, len.saturating_mul(size_of::<T>()))
}

/// Refuses arrays that overlap each other (null or empty ones are ignored):
/// two of them would otherwise be one `&mut` and another reference to the
/// same memory.
pub fn disjoint(parts: &[(usize, usize)]) -> Result<(), Status> {
    for (i, &(a, na)) in parts.iter().enumerate() {
        for &(b, nb) in parts.iter().skip(i + 1) {
            let empty = a == 0 || b == 0 || na == 0 || nb == 0;
            if !empty && a < b.saturating_add(nb) && b < a.saturating_add(na) {
                return Err(Status::Overlap);
            }
        }
    }
    Ok(())
}

/// `len` values at `ptr`, read-only. Null is accepted for `len == 0`.
///
/// # Safety
///
/// `ptr` is null or valid for reads of `len` values for `'a`, and nobody
/// writes them meanwhile.
pub unsafe fn input<'a, T: Plain>(
    ptr: *const T,
    len: usize,
    guard: Option<&SceneHandle>,
) -> Result<&'a [T], Status> {
    if len == 0 {
        return Ok(&[]);
    }
    check::<T>(ptr as usize, len, guard)?;
    // SAFETY: non-null, aligned, size in range, outside the scene buffer;
    // valid for reads by the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts(ptr, len) })
}

/// `len` values at `ptr`, to be written. Null is accepted for `len == 0`.
///
/// # Safety
///
/// `ptr` is null or valid for writes of `len` values for `'a`, and nobody
/// else accesses them meanwhile.
pub unsafe fn output<'a, T: Plain>(
    ptr: *mut T,
    len: usize,
    guard: Option<&SceneHandle>,
) -> Result<&'a mut [T], Status> {
    if len == 0 {
        return Ok(&mut []);
    }
    check::<T>(ptr as usize, len, guard)?;
    // SAFETY: as in `input`, for writes. `T: Plain`, so whatever the memory
    // held is a valid `T` until it is overwritten.
    Ok(unsafe { core::slice::from_raw_parts_mut(ptr, len) })
}

/// One value read from a required pointer.
///
/// # Safety
///
/// As [`input`] with `len == 1`.
pub unsafe fn get<T: Plain>(ptr: *const T, guard: Option<&SceneHandle>) -> Result<T, Status> {
    // SAFETY: forwarded contract.
    let s = unsafe { input(ptr, 1, guard)? };
    s.first().copied().ok_or(Status::NullPointer)
}

/// A required out-parameter, checked before any work is done so that a bad
/// pointer leaves the scene unchanged.
///
/// # Safety
///
/// As [`output`] with `len == 1`.
pub unsafe fn out<'a, T: Plain>(
    ptr: *mut T,
    guard: Option<&SceneHandle>,
) -> Result<&'a mut T, Status> {
    // SAFETY: forwarded contract.
    let s = unsafe { output(ptr, 1, guard)? };
    s.first_mut().ok_or(Status::NullPointer)
}

/// An optional out-parameter: `None` for null.
///
/// # Safety
///
/// As [`output`] with `len == 1`.
pub unsafe fn out_opt<'a, T: Plain>(
    ptr: *mut T,
    guard: Option<&SceneHandle>,
) -> Result<Option<&'a mut T>, Status> {
    if ptr.is_null() {
        return Ok(None);
    }
    // SAFETY: forwarded contract.
    unsafe { out(ptr, guard) }.map(Some)
}
