#!/usr/bin/env python3
"""Scan an AVR image for avr-gcc 5.4's Z-register clobber (the class of GCC PR 56833).

avr-gcc 5.4 (Debian's, and PlatformIO's toolchain-atmelavr) sometimes takes r30 or r31 as the
scratch register of an immediate operand (`ldi r31, K` then `sub r10, r31`: the low registers
r0..r15 take no immediate) while Z = r30:r31 still holds a pointer that the code uses after it
(`st Z, r1`, `adiw r30, 6`): the pointer's high or low byte is then the constant, and the store
lands anywhere (in this project: a crash at boot, `Board::construct`, and a read from 0xfb76,
the preview's `reset()`). Which code shape triggers it is not predictable; the images are
checked after every link instead, and the build fails on a hit.

The pattern, on each straight run of instructions (a call, return or jump ends the run; a
conditional branch does not, its fall-through is followed):
  1. `ldi r30|r31, K` that is not half of a pointer being formed (the other half alone is not
     written within two instructions either side),
  2. that register read as an 8-bit operand by an instruction whose result goes elsewhere
     (sub, sbc, add, adc, and, or, eor, cp, cpc, cpse, mov, st, std, sts, push, out),
  3. then a use of Z as a pointer (ld/ldd/st/std/lpm/elpm through Z, adiw/sbiw r30, movw from
     r30, icall/ijmp, spm) before that register is written again.
A correct program never does 1-2-3 (after the constant, Z is not the pointer any more), so a hit
is a miscompile, or at least code that uses a constant as a pointer's byte.

  python3 firmware/z_scan.py --objdump avr-objdump IMAGE.elf [...]    exit 1 on a hit
  python3 firmware/z_scan.py --self-test                               the pattern on known code
"""
import argparse
import re
import subprocess
import sys

INSN = re.compile(r"^\s*([0-9a-f]+):\s+(?:[0-9a-f]{2} )+\s*\t(\S+)\s*([^;]*)")
FUNC = re.compile(r"^([0-9a-f]+) <(.+)>:$")
HALVES = ("r30", "r31")
READERS = {"sub", "sbc", "add", "adc", "and", "or", "eor", "cp", "cpc", "cpse", "mov", "st", "std",
           "sts", "push", "out"}
ENDS = {"call", "rcall", "ret", "reti", "jmp", "rjmp", "eijmp", "eicall"}
# Instructions that write their first operand (a register) - every one that can name r30/r31.
# (mul/muls/mulsu/fmul* write r0:r1, not their operands.)
WRITERS = {"ldi", "mov", "movw", "ld", "ldd", "lds", "lpm", "elpm", "pop", "in", "add", "adc",
           "sub", "sbc", "subi", "sbci", "and", "andi", "or", "ori", "eor", "com", "neg", "inc",
           "dec", "lsr", "ror", "asr", "swap", "clr", "ser", "bld", "adiw", "sbiw", "cbr", "sbr",
           "lsl", "rol"}


def operands(text):
    return [o.strip() for o in text.split(",") if o.strip()]


def writes(op, args):
    """Registers (of r30, r31) an instruction writes."""
    out = set()
    if op in WRITERS and args:
        first = args[0]
        if op in ("movw", "adiw", "sbiw"):  # register pairs: r30 names Z
            if first == "r30":
                out |= {"r30", "r31"}
        elif first in HALVES:
            out.add(first)
    for a in args:  # post-increment / pre-decrement through Z writes Z
        if a in ("Z+", "-Z"):
            out |= {"r30", "r31"}
    return out


def uses_z(op, args):
    """A use of Z = r30:r31 as a pointer or as a 16-bit value."""
    if op in ("icall", "ijmp", "spm", "eicall", "eijmp"):
        return True
    if op in ("lpm", "elpm") and (not args or any(a.startswith("Z") for a in args)):
        return True
    if any(a in ("Z", "Z+", "-Z") or a.startswith("Z+") for a in args):
        return True
    if op in ("adiw", "sbiw") and args and args[0] == "r30":
        return True
    if op == "movw" and len(args) == 2 and args[1] == "r30":
        return True
    return False


def reads_as_byte(op, args, reg):
    if op not in READERS:
        return False
    if op in ("st", "std", "sts", "push", "out"):
        return bool(args) and args[-1] == reg
    return len(args) == 2 and args[1] == reg and args[0] not in HALVES


def scan(lines):
    """lines: (function, address, op, args). Returns the hits as strings."""
    hits = []
    n = len(lines)
    for i, (fn, addr, op, args) in enumerate(lines):
        if op != "ldi" or not args or args[0] not in HALVES:
            continue
        reg = args[0]
        other = "r30" if reg == "r31" else "r31"
        near = lines[max(0, i - 2):i] + lines[i + 1:i + 3]
        if any(l[0] == fn and writes(l[2], l[3]) == {other} for l in near):
            continue  # a pointer being formed a byte at a time
        read_at = None
        for j in range(i + 1, n):
            f2, a2, op2, args2 = lines[j]
            if f2 != fn or op2 in ENDS:
                break
            if read_at is not None and uses_z(op2, args2):
                hits.append(f"{fn}: ldi {reg} at 0x{addr:x}, read as a byte at 0x{read_at:x}, "
                            f"Z used at 0x{a2:x} ({op2} {', '.join(args2)}) before {reg} is written again")
                break
            if reads_as_byte(op2, args2, reg):
                read_at = a2
            if reg in writes(op2, args2):
                break
    return hits


def parse(text):
    fn, out = "?", []
    for line in text.splitlines():
        m = FUNC.match(line)
        if m:
            fn = m.group(2)
            continue
        m = INSN.match(line)
        if m:
            out.append((fn, int(m.group(1), 16), m.group(2), operands(m.group(3))))
    return out


def disassemble(objdump, elf):
    return subprocess.run([objdump, "-d", elf], check=True, capture_output=True, text=True).stdout


def asm(fn, *insns):
    """Known code in objdump's form, for the self-test."""
    body = "\n".join(f"     {2 * k:x}:\t00 00       \t{s}" for k, s in enumerate(insns))
    return f"00000000 <{fn}>:\n{body}\n"


def self_test():
    bad_construct = asm("Board::construct", "movw\tr30, r24", "ldi\tr31, 0x91", "sub\tr10, r31",
                        "ldi\tr31, 0xFE", "sbc\tr11, r31", "adiw\tr30, 0x06", "st\tZ, r1")
    fine_scratch = asm("fine", "ldi\tr31, 0x1A", "cpse\tr5, r31", "rjmp\t.+2", "st\tZ, r1")
    fine_reload = asm("reload", "ldi\tr31, 0x91", "sub\tr10, r31", "movw\tr30, r24", "st\tZ, r1")
    fine_pointer = asm("pointer", "ldi\tr30, 0x10", "ldi\tr31, 0x01", "cp\tr24, r31", "ld\tr24, Z")
    cases = [(bad_construct, 1), (fine_scratch, 0), (fine_reload, 0), (fine_pointer, 0)]
    ok = True
    for text, want in cases:
        got = scan(parse(text))
        if len(got) != want:
            ok = False
            print(f"self-test: {parse(text)[0][0]}: {len(got)} hits, expected {want}: {got}")
    print("z_scan self-test: " + ("passed" if ok else "FAILED"))
    return 0 if ok else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("elf", nargs="*")
    ap.add_argument("--objdump", default="avr-objdump")
    ap.add_argument("--self-test", action="store_true")
    a = ap.parse_args()
    if a.self_test:
        return self_test()
    status = 0
    for elf in a.elf:
        hits = scan(parse(disassemble(a.objdump, elf)))
        for h in hits:
            print(f"{elf}: avr-gcc Z clobber (PR 56833 class): {h}", file=sys.stderr)
        print(f"z_scan: {elf}: {len(hits)} Z-clobber patterns")
        status |= 1 if hits else 0
    return status


if __name__ == "__main__":
    sys.exit(main())
