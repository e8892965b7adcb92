//! Cost measurements: instructions through SysTick, stack through painting.
//!
//! **Instructions.** QEMU does not emulate the DWT cycle counter, but with
//! `-icount shift=0` every instruction advances virtual time by 1 ns, and
//! SysTick on the core clock (25 MHz on mps2-an386) then ticks once every
//! 40 instructions. [`Counter::calibrate`] checks that ratio against a loop
//! of known length, so a run without `-icount` shows up as a wrong ratio
//! instead of wrong numbers. These are instructions, not cycles.
//!
//! **Stack.** [`paint`] fills the free stack with a pattern; after the code
//! of interest, [`lowest_touched`] finds the deepest word that changed.

use core::ptr::{addr_of, read_volatile, write_volatile};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;

/// SysTick's counter is 24 bits wide and counts down.
const MASK: u32 = 0x00ff_ffff;

/// Instructions per SysTick tick, measured.
#[derive(Clone, Copy)]
pub struct Calibration {
    /// Instructions of the calibration loop.
    pub instructions: u64,
    /// Ticks it took.
    pub ticks: u64,
}

impl Calibration {
    /// `ticks` converted to instructions.
    pub fn instructions(&self, ticks: u64) -> u64 {
        (ticks * self.instructions)
            .checked_div(self.ticks)
            .unwrap_or(0)
    }
}

/// A free-running SysTick.
pub struct Counter {
    _syst: SYST,
}

impl Counter {
    /// Starts SysTick on the core clock, wrapping every 2²⁴ ticks.
    pub fn new(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(MASK);
        syst.clear_current();
        syst.enable_counter();
        Self { _syst: syst }
    }

    /// The current count (counts down).
    #[inline(always)]
    pub fn now(&self) -> u32 {
        SYST::get_current()
    }

    /// Ticks from `start` to now (less than one wrap: 2²⁴ ticks, ~670 M
    /// instructions).
    #[inline(always)]
    pub fn since(&self, start: u32) -> u32 {
        start.wrapping_sub(self.now()) & MASK
    }

    /// Times two runs of a two-instruction loop; their difference cancels
    /// the fixed overhead of the measurement.
    pub fn calibrate(&self) -> Calibration {
        const SHORT: u32 = 100_000;
        const LONG: u32 = 1_100_000;
        let t = self.now();
        spin(SHORT);
        let short = self.since(t);
        let t = self.now();
        spin(LONG);
        let long = self.since(t);
        Calibration {
            instructions: 2 * u64::from(LONG - SHORT),
            ticks: u64::from(long.wrapping_sub(short)),
        }
    }
}

/// Runs `subs; bne` `n` times: exactly `2 n` instructions.
#[inline(never)]
fn spin(n: u32) {
    // SAFETY: touches only its own register and the flags.
    unsafe {
        core::arch::asm!(
            "2:",
            "subs {n}, {n}, #1",
            "bne 2b",
            n = inout(reg) n => _,
            options(nomem, nostack),
        );
    }
}

/// The pattern of unused stack.
const PAINT: u32 = 0xC0FE_F00D;

extern "C" {
    /// Lowest address of the stack (cortex-m-rt: the end of `.bss`/`.uninit`).
    static _stack_end: u32;
    /// One past the highest address of the stack (the top of RAM).
    static _stack_start: u32;
    /// Start of RAM.
    static _ram_start: u32;
}

fn stack_end() -> usize {
    addr_of!(_stack_end) as usize
}

/// Top of the stack (its initial value).
pub fn stack_top() -> usize {
    addr_of!(_stack_start) as usize
}

/// Bytes of RAM taken by statics (`.data`, `.bss`, `.uninit`): everything
/// below the stack.
pub fn static_ram() -> usize {
    stack_end() - addr_of!(_ram_start) as usize
}

/// Current stack pointer.
#[inline(always)]
pub fn sp() -> usize {
    cortex_m::register::msp::read() as usize
}

/// Paints the free stack below the caller's frame.
#[inline(never)]
pub fn paint() {
    // Leave this function's own frame (well under 64 bytes) alone.
    let top = sp() - 64;
    let mut p = stack_end();
    while p < top {
        // SAFETY: between the end of the statics and below the live stack:
        // memory nobody uses now.
        unsafe { write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}

/// Lowest stack address written since the last [`paint`].
#[inline(never)]
pub fn lowest_touched() -> usize {
    let top = stack_top();
    let mut p = stack_end();
    // SAFETY: reads RAM between the statics and the top of the stack.
    while p < top && unsafe { read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    p
}
