#!/usr/bin/env python3
"""Estimates Cortex-M4F cycles from the instructions the firmware executes.

QEMU counts instructions, not cycles. This script turns an execution trace
into a cycle estimate with the per-instruction timings of the Cortex-M4
Technical Reference Manual (ARM DDI 0439, tables 3-1 and 7-1), assuming
zero-wait-state memory (code from the flash accelerator's cache or RAM, data
in SRAM):

* data processing, MUL, IT, VADD/VSUB/VMUL/VNEG/VABS, VMOV, VCMP, VMRS,
  VCVT: 1 cycle; MLA/MLS: 2;
* VMLA/VMLS/VNMLA/VNMLS/VFMA/VFMS: 3; VDIV, VSQRT: 14; UDIV/SDIV: 7 (2..12);
* LDR/STR/VLDR/VSTR: 2, or 1 right after another load or store (the
  address and data phases pipeline); LDM/STM/PUSH/POP/VLDM/VSTM/VPUSH/VPOP:
  1 + registers;
* a taken branch (or BL, BX, a POP or LDR into pc): 1 + 2 for the pipeline
  refill; a conditional branch not taken: 1.

Usage (the whole run of one firmware image):

    qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \\
        -monitor none -serial null -semihosting-config enable=on,target=native \\
        -icount shift=0 -d in_asm,exec,nochain -D /dev/stdout \\
        -kernel corofem-firmware | python3 cycle_model.py

It prints the instruction mix, the modelled cycles per instruction (CPI)
and, from the `corofem-firmware` line in the same output, the step's
estimated cycles and the largest scene that fits a 1 kHz loop at 168 MHz.
"""

import collections
import re
import sys

CONDS = {"eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le", "al"}
MAC = {"vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms"}
SLOW = {"vdiv": 14, "vsqrt": 14, "udiv": 7, "sdiv": 7, "mla": 2, "mls": 2}
SINGLE_MEM = {"ldr", "ldrb", "ldrh", "ldrsb", "ldrsh", "str", "strb", "strh", "vldr", "vstr",
              "ldrex", "strex"}
DOUBLE_MEM = {"ldrd", "strd"}
MULTI_MEM = {"ldm", "ldmia", "ldmdb", "stm", "stmia", "stmdb", "push", "pop",
             "vldm", "vldmia", "vstm", "vstmia", "vstmdb", "vpush", "vpop"}
BRANCH = {"b", "bl", "blx", "bx", "cbz", "cbnz", "tbb", "tbh"}
REFILL = 2

LINE = re.compile(r"^0x([0-9a-f]+):\s+((?:[0-9a-f]{4} ?)+)\s+(\S+)\s*(.*)$")
TRACE = re.compile(r"^Trace \d+: (0x[0-9a-f]+) \[[0-9a-f]+/([0-9a-f]+)/")


def base(mnemonic):
    """Mnemonic without width/type suffixes and condition code."""
    m = mnemonic.split(".")[0]
    if m in BRANCH or m in SINGLE_MEM or m in MULTI_MEM or m in DOUBLE_MEM:
        return m
    if len(m) == 3 and m[0] == "b" and m[1:] in CONDS:
        return "b"
    if len(m) > 2 and m[-2:] in CONDS and m not in ("vcmpe",):
        stripped = m[:-2]
        if stripped and stripped not in ("b",):
            return stripped
    return m


def registers(operands):
    """Registers in a {register list}."""
    inner = operands[operands.find("{") + 1:operands.find("}")]
    n = 0
    for part in inner.split(","):
        part = part.strip()
        if "-" in part:
            lo, hi = part.split("-")
            n += int(hi.strip()[1:]) - int(lo.strip()[1:]) + 1
        elif part:
            n += 1
    return max(n, 1)


def block_cost(insns):
    """(cycles without the final branch's refill, class counts, writes pc?)."""
    cycles = 0
    classes = collections.Counter()
    prev_mem = False
    for m, ops in insns:
        b = base(m)
        if b in SINGLE_MEM:
            cycles += 1 if prev_mem else 2
            classes["load/store"] += 1
            prev_mem = True
            continue
        prev_mem = False
        if b in DOUBLE_MEM:
            cycles += 3
            classes["load/store"] += 1
        elif b in MULTI_MEM:
            cycles += 1 + registers(ops)
            classes["load/store multiple"] += 1
        elif b in MAC:
            cycles += 3
            classes["fp multiply-accumulate"] += 1
        elif b in SLOW:
            cycles += SLOW[b]
            classes[b] += 1
        elif b in BRANCH:
            cycles += 1
            classes["branch"] += 1
        elif b.startswith("v"):
            cycles += 1
            classes["fp other"] += 1
        else:
            cycles += 1
            classes["integer"] += 1
    return cycles, classes


def main():
    blocks = {}  # host TB address -> (cycles, classes, n, end pc, last mnemonic, last operands)
    pending = None
    insns = []
    last_pc = None
    total = collections.Counter()
    cycles = 0
    refills = 0
    n_insns = 0
    prev = None  # (end pc, ends with a branch)
    report = None
    for line in sys.stdin:
        if line.startswith("corofem-firmware "):
            report = line.strip()
            continue
        if line.startswith("IN:"):
            insns = []
            pending = True
            continue
        m = LINE.match(line)
        if m and pending:
            pc = int(m.group(1), 16)
            size = len(m.group(2).replace(" ", "")) // 2
            insns.append((m.group(3), m.group(4)))
            last_pc = pc + size
            continue
        t = TRACE.match(line)
        if not t:
            continue
        host = t.group(1)
        pc = int(t.group(2), 16)
        if pending and insns:
            c, k = block_cost(insns)
            lm, lo = insns[-1]
            blocks[host] = (c, k, len(insns), last_pc, base(lm), lo)
            pending = False
        info = blocks.get(host)
        if info is None:
            continue
        # The previous block's last instruction: did control leave it by a
        # taken branch (this block does not start where it ended)?
        if prev is not None and prev[1] and pc != prev[0]:
            refills += 1
        c, k, n, end, lm, lo = info
        cycles += c
        total.update(k)
        n_insns += n
        writes_pc = lm in BRANCH or (lm in ("pop", "ldm", "ldmia") and "pc" in lo) or (
            lm == "ldr" and lo.startswith("pc"))
        prev = (end, writes_pc)
    cycles += REFILL * refills
    print(f"instructions executed: {n_insns}")
    for k, v in total.most_common():
        print(f"  {k:24s} {v:12d}  {100.0 * v / max(n_insns, 1):5.1f}%")
    print(f"taken branches (refill {REFILL} cycles): {refills}")
    cpi = cycles / max(n_insns, 1)
    print(f"modelled cycles: {cycles}  CPI {cpi:.3f}")
    if report:
        fields = dict(f.split("=", 1) for f in report.split()[1:] if "=" in f)
        step = int(fields["instr_per_step"])
        tets = int(fields["tets"])
        per_tet = step * cpi / tets
        budget = 168_000
        print(f"{fields['cells']}: {step} instructions per step -> ~{step * cpi:.0f} cycles "
              f"({step * cpi / 168e3:.3f} ms at 168 MHz); {per_tet:.0f} cycles per tetrahedron-step; "
              f"a 1 kHz loop at 168 MHz fits ~{budget / per_tet:.0f} tetrahedra")


if __name__ == "__main__":
    main()
