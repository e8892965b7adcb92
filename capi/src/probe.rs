//! Probes inside memory the caller provides.
//!
//! ```text
//!  caller's buffer (any address, `corofem_probes_bytes` long)
//!  ┌─────┬────────────────┬──────────────────────────────────────────┐
//!  │ pad │ ProbesHandle   │ Probe × capacity                         │
//!  │ 0–7 │ magic, buffer, │ shape, pose at the step's start and end, │
//!  │     │ capacity, count│ force, contacts, friction                │
//!  └─────┴────────────────┴──────────────────────────────────────────┘
//!        ▲ the handle: aligned to the pointer size; the probes follow
//! ```
//!
//! A set of probes is the caller's, as the core's `Probe`s are: it belongs
//! to no scene, and `corofem_step_probes` passes its probes to a scene's
//! step as one slice (`Scene::step_with_probes`), which moves them and
//! writes back their forces. Probes are added one at a time and are never
//! removed: only the first `count` slots hold probes, and only those are
//! ever formed into references. Initialising the buffer again empties it.
//!
//! All the raw-pointer work on probe buffers is in this file.
//!
//! Without the feature `probe` only the handle's type is here, for the
//! functions' signatures, which then return `Status::Unsupported`.

#[cfg(feature = "probe")]
use core::alloc::Layout;
#[cfg(feature = "probe")]
use core::mem::size_of;

#[cfg(feature = "probe")]
use corofem_core::Probe;

#[cfg(feature = "probe")]
use crate::status::Status;

/// A live set of probes (a live scene is `0xC0FE_0001`, a surface
/// `0xC0FE_0005`).
#[cfg(feature = "probe")]
const MAGIC: u32 = 0xC0FE_0007;

/// The probe set's handle: the front of the caller's probe buffer. Opaque
/// to C.
#[cfg_attr(not(feature = "probe"), allow(dead_code))]
pub struct ProbesHandle {
    /// [`MAGIC`] while the set is live.
    magic: u32,
    /// The address of this handle when it was made.
    this: usize,
    /// The caller's whole buffer `[start, end)`: arrays passed in or out
    /// must not overlap it.
    buffer: (usize, usize),
    /// Probe slots.
    capacity: usize,
    /// Probes made so far: the slots `0..count` hold them.
    count: usize,
}

/// Where the probes go, relative to the aligned start.
#[cfg(feature = "probe")]
struct Plan {
    probes: usize,
    size: usize,
    align: usize,
}

#[cfg(feature = "probe")]
fn plan(capacity: usize) -> Option<Plan> {
    let head = Layout::new::<ProbesHandle>();
    let (l, probes) = head.extend(Layout::array::<Probe>(capacity).ok()?).ok()?;
    Some(Plan {
        probes,
        size: l.size(),
        align: l.align(),
    })
}

/// Bytes a buffer at any address needs for `capacity` probes (plus
/// `align − 1` bytes of slack). None is an invalid argument; more than a
/// step takes (`MAX_PROBES`) is [`Status::Capacity`].
#[cfg(feature = "probe")]
pub fn probes_bytes(capacity: usize) -> Result<usize, Status> {
    if capacity == 0 {
        return Err(Status::InvalidArgument);
    }
    if capacity > corofem_core::MAX_PROBES {
        return Err(Status::Capacity);
    }
    let p = plan(capacity).ok_or(Status::Capacity)?;
    p.size.checked_add(p.align - 1).ok_or(Status::Capacity)
}

/// Initialises an empty set of `capacity` probes in `buffer` and returns
/// its handle. A set that lived in the buffer before is emptied.
///
/// # Safety
///
/// `buffer` is null or valid for writes of `bytes` bytes, and nothing else
/// uses that memory while the set lives.
#[cfg(feature = "probe")]
pub unsafe fn init(
    buffer: *mut u8,
    bytes: usize,
    capacity: usize,
) -> Result<*mut ProbesHandle, Status> {
    if buffer.is_null() {
        return Err(Status::NullPointer);
    }
    let need = probes_bytes(capacity)?;
    let p = plan(capacity).ok_or(Status::Capacity)?;
    let start = buffer as usize;
    let end = start.checked_add(bytes).ok_or(Status::InvalidArgument)?;
    // As for scenes: the worst-case padding is counted, so a size that
    // works once works at every address.
    if bytes < need {
        return Err(Status::BufferTooSmall);
    }
    let pad = start.wrapping_neg() & (p.align - 1);
    // SAFETY: `pad + size_of::<ProbesHandle>() <= pad + p.size <= need <=
    // bytes`: the handle lies inside the caller's buffer, aligned because
    // `pad` aligns the start to `p.align`, the largest alignment of the
    // parts. The slots stay uninitialised until a probe is made in them.
    unsafe {
        let handle = buffer.add(pad).cast::<ProbesHandle>();
        handle.write(ProbesHandle {
            magic: MAGIC,
            this: handle as usize,
            buffer: (start, end),
            capacity,
            count: 0,
        });
        Ok(handle)
    }
}

#[cfg(feature = "probe")]
crate::arena::stamped!(ProbesHandle);

/// A live set of probes: its header, and the caller's pointer to it,
/// through which the slots that follow it are reached (a reference to the
/// header covers the header only).
#[cfg(feature = "probe")]
pub struct Probes<'a> {
    head: &'a mut ProbesHandle,
    slots: *mut Probe,
}

/// The live set behind a handle.
///
/// # Safety
///
/// `h` is null or points to at least `size_of::<ProbesHandle>()` readable
/// bytes (a handle from [`init`] whose buffer is still allocated, or any
/// other readable memory, which is then refused), and no other call uses
/// the same set at the same time.
#[cfg(feature = "probe")]
pub unsafe fn probes<'a>(h: *mut ProbesHandle) -> Result<Probes<'a>, Status> {
    // SAFETY: the caller's contract.
    unsafe { crate::arena::check_stamp(h.cast_const(), MAGIC)? };
    // SAFETY: a live handle written by `init` at this very address, whose
    // capacity `init` checked with `plan`; used by this call alone.
    let head = unsafe { &mut *h };
    let p = plan(head.capacity).ok_or(Status::InvalidHandle)?;
    // SAFETY: `init` laid the slots out at `p.probes` from the handle,
    // inside the caller's buffer.
    let slots = unsafe { h.cast::<u8>().add(p.probes).cast::<Probe>() };
    Ok(Probes { head, slots })
}

#[cfg(feature = "probe")]
impl Probes<'_> {
    /// The probes made so far.
    pub fn count(&self) -> usize {
        self.head.count
    }

    /// Adds `probe` in the next free slot and returns its index;
    /// [`Status::Capacity`] when every slot holds one.
    pub fn add(&mut self, probe: Probe) -> Result<usize, Status> {
        let i = self.head.count;
        if i >= self.head.capacity {
            return Err(Status::Capacity);
        }
        // SAFETY: `i < capacity`: the slot is inside the buffer (`init`),
        // aligned, and no reference to it exists (only `0..count` are ever
        // formed into references).
        unsafe { self.slots.add(i).write(probe) };
        self.head.count = i + 1;
        Ok(i)
    }

    /// The probes made so far, to be read, changed or stepped.
    pub fn all(&mut self) -> &mut [Probe] {
        // SAFETY: the slots `0..count` were written by `add`; the set is
        // used by this call alone (the caller's contract), and the slice
        // borrows `self`, so no other reference to them exists meanwhile.
        unsafe { core::slice::from_raw_parts_mut(self.slots, self.head.count) }
    }

    /// Probe `index`, or [`Status::IndexOutOfRange`] if none was made there.
    pub fn get(&mut self, index: usize) -> Result<&mut Probe, Status> {
        self.all().get_mut(index).ok_or(Status::IndexOutOfRange)
    }

    /// The caller's buffer `[start, end)`.
    pub fn buffer(&self) -> (usize, usize) {
        self.head.buffer
    }

    /// Whether `len` elements of `T` at `addr` overlap the probe buffer.
    pub fn overlaps<T>(&self, addr: usize, len: usize) -> bool {
        let bytes = len.saturating_mul(size_of::<T>());
        let (start, end) = self.head.buffer;
        bytes > 0 && addr < end && addr.saturating_add(bytes) > start
    }
}

#[cfg(all(test, feature = "probe"))]
mod tests {
    use super::*;

    #[test]
    fn sizes_add_up() {
        let b = probes_bytes(3).unwrap();
        let parts = size_of::<ProbesHandle>() + 3 * size_of::<Probe>();
        // Slack: the padding between the handle and the probes, and up to
        // `align − 1` bytes before the handle, both below 8.
        assert!(b >= parts && b < parts + 16, "{b} vs {parts}");
        assert_eq!(probes_bytes(0), Err(Status::InvalidArgument));
        let most = corofem_core::MAX_PROBES;
        assert!(probes_bytes(most).is_ok());
        assert_eq!(probes_bytes(most + 1), Err(Status::Capacity));
    }
}
