//! The defmt global logger: rzCOBS-encoded frames written through
//! semihosting to the host file `defmt.bin` (in QEMU's working directory).
//! Decode with `defmt-print -e <firmware ELF> < defmt.bin`.
//!
//! On a real board replace this module with `defmt-rtt` and a probe.

use core::cell::UnsafeCell;

use cortex_m_semihosting::nr;

use crate::host::File;

/// Host file that receives the frames (NUL-terminated for semihosting).
const LOG_FILE: &[u8] = b"defmt.bin\0";

#[defmt::global_logger]
struct Logger;

/// Everything the logger owns. Only touched between `acquire` and
/// `release`, which hold a critical section: interrupts are off for the
/// whole frame, so no frame can start inside another on this single core.
struct State {
    restore: critical_section::RestoreState,
    encoder: defmt::Encoder,
    sink: Sink,
}

/// Encoded bytes on their way to the host file.
struct Sink {
    /// Opened on the first flush; `Some(None)` if the host refused.
    file: Option<Option<File>>,
    buf: [u8; 256],
    len: usize,
}

struct Shared(UnsafeCell<State>);
// SAFETY: single core, and the critical section serialises every access.
unsafe impl Sync for Shared {}

static STATE: Shared = Shared(UnsafeCell::new(State {
    restore: critical_section::RestoreState::invalid(),
    encoder: defmt::Encoder::new(),
    sink: Sink {
        file: None,
        buf: [0; 256],
        len: 0,
    },
}));

impl Sink {
    fn push(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if self.len == self.buf.len() {
                self.flush();
            }
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
                self.len += 1;
            }
        }
    }

    fn flush(&mut self) {
        let file = *self
            .file
            .get_or_insert_with(|| File::open(LOG_FILE, nr::open::W_TRUNC_BINARY));
        if let (Some(file), Some(bytes)) = (file, self.buf.get(..self.len)) {
            file.write(bytes);
        }
        self.len = 0;
    }
}

/// The logger's state.
///
/// # Safety
/// Only between `acquire` and `release` (inside the critical section), and
/// only one reference at a time.
#[allow(clippy::mut_from_ref)]
unsafe fn state() -> &'static mut State {
    // SAFETY: see the function's contract.
    unsafe { &mut *STATE.0.get() }
}

// SAFETY: `acquire` takes a critical section that `release` gives back, so
// frames never interleave.
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        // SAFETY: released in `release`.
        let restore = unsafe { critical_section::acquire() };
        // SAFETY: inside the critical section just taken.
        let State {
            restore: slot,
            encoder,
            sink,
        } = unsafe { state() };
        *slot = restore;
        encoder.start_frame(|bytes| sink.push(bytes));
    }

    unsafe fn flush() {
        // SAFETY: called between acquire and release.
        unsafe { state() }.sink.flush();
    }

    unsafe fn release() {
        // SAFETY: called between acquire and release.
        let State {
            restore,
            encoder,
            sink,
        } = unsafe { state() };
        encoder.end_frame(|bytes| sink.push(bytes));
        sink.flush();
        // SAFETY: pairs with the acquire in `acquire`.
        unsafe { critical_section::release(*restore) };
    }

    unsafe fn write(bytes: &[u8]) {
        // SAFETY: called between acquire and release.
        let State { encoder, sink, .. } = unsafe { state() };
        encoder.write(bytes, |b| sink.push(b));
    }
}
