/* Minimal Cortex-M4F start-up for running examples/haptic_loop.c in QEMU
 * (mps2-an386): vector table, FPU on, .data/.bss set up, semihosting for
 * printf (newlib's librdimon) and for the exit code. */
#include <stdint.h>

extern uint32_t __stack_top, __data_load, __data_start, __data_end, __bss_start, __bss_end;
extern int main(int argc, char **argv);
extern void initialise_monitor_handles(void);

/* Semihosting SYS_EXIT: QEMU exits 0 for "application exit", 1 otherwise. */
static void __attribute__((noreturn)) semihosting_exit(int status) {
    register uint32_t r0 __asm__("r0") = 0x18;
    register uint32_t r1 __asm__("r1") = status == 0 ? 0x20026u : 0x20023u;
    __asm__ volatile("bkpt 0xab" : : "r"(r0), "r"(r1) : "memory");
    for (;;) {
    }
}

/* newlib's exit() ends here. */
void _exit(int status) { semihosting_exit(status); }

void Reset_Handler(void) {
    /* CPACR: full access to CP10/CP11, the FPU (the staticlib uses it). */
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20;
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    for (uint32_t *s = &__data_load, *d = &__data_start; d < &__data_end;) *d++ = *s++;
    for (uint32_t *d = &__bss_start; d < &__bss_end;) *d++ = 0;
    initialise_monitor_handles();
    static char arg0[] = "haptic_loop", arg1[] = "box", arg2[] = "2000";
    static char *argv[] = {arg0, arg1, arg2, 0};
    semihosting_exit(main(3, argv));
}

static void Fault_Handler(void) { semihosting_exit(1); }

__attribute__((section(".vectors"), used)) static const void *const vectors[16] = {
    &__stack_top, (const void *)Reset_Handler, (const void *)Fault_Handler,
    (const void *)Fault_Handler, (const void *)Fault_Handler, (const void *)Fault_Handler,
    (const void *)Fault_Handler,
};
