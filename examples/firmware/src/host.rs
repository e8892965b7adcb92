//! Talking to the host through semihosting: plain text lines on its stdout
//! (what CI reads) and binary files (the defmt log). Numbers are formatted
//! by hand rather than with `core::fmt`, so that no panicking branch comes in
//! with the formatting machinery.

use cortex_m_semihosting::{nr, syscall};

/// A host file handle.
#[derive(Clone, Copy)]
pub struct File(usize);

impl File {
    /// Opens `name` (NUL-terminated) with a semihosting `open` mode
    /// (`nr::open::*`); the name `":tt"` is the host's console.
    pub fn open(name: &[u8], mode: usize) -> Option<File> {
        let len = name.len().saturating_sub(1);
        // SAFETY: SYS_OPEN reads `len` bytes of `name`, which outlives the call.
        let fd = unsafe { syscall!(OPEN, name.as_ptr(), mode, len) };
        (fd as isize >= 0).then_some(File(fd))
    }

    /// The host's standard output.
    pub fn stdout() -> Option<File> {
        File::open(b":tt\0", nr::open::W_TRUNC)
    }

    /// Writes all of `bytes`; `false` if the host refused.
    pub fn write(self, bytes: &[u8]) -> bool {
        // SAFETY: SYS_WRITE reads `bytes.len()` bytes of `bytes`.
        let left = unsafe { syscall!(WRITE, self.0, bytes.as_ptr(), bytes.len()) };
        left == 0
    }
}

/// One line of text, built in a fixed buffer (longer lines are cut).
pub struct Line {
    buf: [u8; 512],
    len: usize,
}

impl Line {
    pub const fn new() -> Self {
        Self {
            buf: [0; 512],
            len: 0,
        }
    }

    fn byte(&mut self, b: u8) -> &mut Self {
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = b;
            self.len += 1;
        }
        self
    }

    pub fn str(&mut self, s: &str) -> &mut Self {
        for &b in s.as_bytes() {
            self.byte(b);
        }
        self
    }

    /// Decimal.
    pub fn u64(&mut self, mut v: u64) -> &mut Self {
        let mut digits = [0u8; 20];
        let mut n = 0;
        for d in digits.iter_mut() {
            *d = b'0' + (v % 10) as u8;
            v /= 10;
            n += 1;
            if v == 0 {
                break;
            }
        }
        for &d in digits.iter().take(n).rev() {
            self.byte(d);
        }
        self
    }

    /// `value / 10^places` with `places` (at most 9) decimals.
    pub fn fixed(&mut self, value: u64, places: u32) -> &mut Self {
        let mut scale = 1u64;
        for _ in 0..places.min(9) {
            scale *= 10;
        }
        // `checked_*`: no division-by-zero branch, even one that cannot happen.
        self.u64(value.checked_div(scale).unwrap_or(0));
        if scale > 1 {
            self.byte(b'.');
            let frac = value.checked_rem(scale).unwrap_or(0);
            let mut div = scale / 10;
            while div > 0 {
                self.byte(b'0' + ((frac / div) % 10) as u8);
                div /= 10;
            }
        }
        self
    }

    /// A signed force in millinewtons as newtons with three decimals.
    pub fn newtons(&mut self, f: f32) -> &mut Self {
        if !f.is_finite() {
            return self.str("nan");
        }
        if f < 0.0 {
            self.byte(b'-');
        }
        // Saturating conversion; forces here are far below 4e15 N.
        let milli = (f.abs() * 1000.0 + 0.5) as u64;
        self.fixed(milli, 3)
    }

    /// `0x` and 16 hexadecimal digits.
    pub fn hex64(&mut self, v: u64) -> &mut Self {
        self.str("0x");
        for i in (0..16).rev() {
            let nibble = ((v >> (4 * i)) & 0xf) as u8;
            self.byte(if nibble < 10 {
                b'0' + nibble
            } else {
                b'a' + nibble - 10
            });
        }
        self
    }

    /// Sends the line and a newline to the host's stdout.
    pub fn print(&mut self) {
        self.byte(b'\n');
        if let (Some(out), Some(text)) = (File::stdout(), self.buf.get(..self.len)) {
            out.write(text);
        }
        self.len = 0;
    }
}
