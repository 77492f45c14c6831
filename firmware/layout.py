#!/usr/bin/env python3
"""Function order for the firmware's second link: calls within reach of a 2-byte RCALL.

The AVR's CALL and JMP take 4 bytes; the linker's relaxation (--relax) turns them into 2-byte
RCALL/RJMP where the target lies within +-4 KB. In the default order the soft-float library
sits at the end of the 30 KB image, out of reach of most of its ~400 call sites. This script reads
a first link (built with -ffunction-sections at link time, its map file and its disassembly),
orders the functions so that callers lie near their callees (the soft-float block, libgcc, the
console's reply helpers ...), and writes a copy of the linker's default script whose .text lists
the sections in that order. The second link uses it; anything not listed (a function renamed
since) falls through to the script's usual `*(.text.*)`, so a stale order costs bytes, never
correctness. The library blocks keep their internal order (their own RCALLs stay in reach).

usage: layout.py --map first.map --elf first.elf --objdump avr-objdump --ld avr-ld
                 --emulation avr5 -o order.ld
"""
import argparse
import math
import random
import re
import subprocess
import sys

try:  # (only faster: the same scores, so the same order, without it)
    import numpy as np
except ImportError:
    np = None

REACH = 4094  # bytes either way of an RCALL/RJMP (2 K words, the PC after the instruction)


def sections_from_map(path):
    """[(name, start, size, file)] of the input sections placed in .text, in address order."""
    text = open(path).read()
    at = text.find('Linker script and memory map')
    if at < 0:
        sys.exit(f'{path}: no memory map')
    lines = text[at:].splitlines()
    out = []
    i = 0
    pat_full = re.compile(r'^ (\.text\S*)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$')
    pat_name = re.compile(r'^ (\.text\S*)$')
    pat_rest = re.compile(r'^\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$')
    while i < len(lines):
        m = pat_full.match(lines[i])
        if m:
            out.append((m.group(1), int(m.group(2), 16), int(m.group(3), 16), m.group(4)))
        else:
            m = pat_name.match(lines[i])
            if m and i + 1 < len(lines):
                r = pat_rest.match(lines[i + 1])
                if r:
                    out.append((m.group(1), int(r.group(1), 16), int(r.group(2), 16), r.group(3)))
                    i += 1
        i += 1
    return [s for s in out if s[2] > 0]


def block_of(name, path):
    """The unit a section moves with: a library's block (kept whole), or the section itself."""
    if '.ltrans' in path:  # the program's own (LTO's output objects)
        if name == '.text':
            return None  # crt's and plain .text: fixed place
        return name
    if name == '.text.avr-libc.fplib':
        # Each soft-float member alone: between members they call with CALL/JMP (relaxable), so
        # __mulsf3 can sit near its callers and __divsf3 near its own.
        m = re.match(r'.*/(lib[^/]+\.a)\(([^)]+)\)$', path)
        return f'*{m.group(1)}:{m.group(2)}(.text.avr-libc.fplib)' if m else '*(.text.avr-libc.fplib)'
    if name.startswith('.text.libgcc'):
        return '*(.text.libgcc*)'
    if name == '.text.avr-libc':
        return '*(.text.avr-libc)'
    return None


def calls_from_elf(elf, objdump):
    """[(site address, target address)] of every CALL/JMP/RCALL/RJMP with a symbolic target."""
    dis = subprocess.run([objdump, '-d', elf], capture_output=True, text=True, check=True).stdout
    out = []
    pat = re.compile(r'^\s*([0-9a-f]+):\s+(?:[0-9a-f]{2} )+\s*(call|jmp|rcall|rjmp)\s+\S+\s+;\s+0x([0-9a-f]+)')
    for line in dis.splitlines():
        m = pat.match(line)
        if m:
            out.append((int(m.group(1), 16), int(m.group(3), 16)))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--map', required=True)
    ap.add_argument('--elf', required=True)
    ap.add_argument('--objdump', default='avr-objdump')
    ap.add_argument('--ld', default='avr-ld')
    ap.add_argument('--emulation', default='avr5')
    ap.add_argument('-o', '--out', required=True)
    a = ap.parse_args()

    secs = sections_from_map(a.map)
    # Units: the sections of one block move together (a block's extent in the first link is
    # from its first section's start to its last one's end).
    units = []  # [pattern, first start, starts, end]
    index = {}
    for name, start, size, path in secs:
        b = block_of(name, path)
        if b is None:
            continue
        if b in index:
            u = units[index[b]]
            u[2].append(start)
            u[3] = max(u[3], start + size)
        else:
            index[b] = len(units)
            units.append([b, start, [start], start + size])
    if not units:
        sys.exit('layout.py: no function sections in the map (link with -ffunction-sections)')
    size = [u[3] - u[1] for u in units]
    lo = [u[1] for u in units]

    def unit_at(addr):
        for k, u in enumerate(units):
            if u[1] <= addr < u[3]:
                return k
        return None

    edges = []  # (caller unit, offset in it, callee unit, offset in it)
    for site, target in calls_from_elf(a.elf, a.objdump):
        cu, tu = unit_at(site), unit_at(target)
        if cu is None or tu is None or cu == tu:
            continue
        edges.append((cu, site - lo[cu], tu, target - lo[tu]))

    by_unit = [[] for _ in units]
    for e in edges:
        by_unit[e[0]].append(e)
        by_unit[e[2]].append(e)

    if np is not None:
        e_cu = np.array([e[0] for e in edges])
        e_tu = np.array([e[2] for e in edges])
        e_off = np.array([e[3] - e[1] - 2 for e in edges])
        sizes = np.array(size)

        def score(order):
            pos = np.empty(len(size), dtype=np.int64)
            o = np.array(order)
            pos[o] = np.cumsum(sizes[o]) - sizes[o]
            return int(np.count_nonzero(np.abs(pos[e_tu] - pos[e_cu] + e_off) <= REACH)), None
    else:
        def score(order):
            pos = {}
            at = 0
            for k in order:
                pos[k] = at
                at += size[k]
            return sum(1 for cu, co, tu, to in edges if abs(pos[tu] + to - (pos[cu] + co + 2)) <= REACH), None

    # Start from today's order; move one unit at a time to the place that keeps the most calls
    # in reach, until no move helps.
    order = sorted(range(len(units)), key=lambda k: lo[k])
    best, _ = score(order)
    improved = True
    rounds = 0
    while improved and rounds < 8:
        improved = False
        rounds += 1
        for k in sorted(range(len(units)), key=lambda k: -len(by_unit[k])):
            if not by_unit[k]:
                continue
            rest = [u for u in order if u != k]
            cand_best, cand_at = best, None
            for at in range(len(rest) + 1):
                s, _ = score(rest[:at] + [k] + rest[at:])
                if s > cand_best:
                    cand_best, cand_at = s, at
            if cand_at is not None:
                order = rest[:cand_at] + [k] + rest[cand_at:]
                best = cand_best
                improved = True
    # Then annealing (a fixed seed: the same first link gives the same order): random moves of
    # one unit or a run of a few, a worse order accepted with a probability that falls to zero;
    # the best order seen is kept. (The moves above stop in a local optimum.)
    rng = random.Random(12)
    cur, cur_order = best, order
    best_order = order
    steps = 100000
    for step in range(steps):
        temp = max(0.05, 3.0 * (1.0 - step / steps))
        o = cur_order[:]
        i = rng.randrange(len(o))
        n = rng.randint(1, 6)
        seg = o[i:i + n]
        del o[i:i + n]
        j = rng.randrange(len(o) + 1)
        o[j:j] = seg
        s, _ = score(o)
        if s >= cur or rng.random() < math.exp((s - cur) / temp):
            cur, cur_order = s, o
            if s > best:
                best, best_order = s, o
    order = best_order
    before, _ = score(sorted(range(len(units)), key=lambda k: lo[k]))
    total = len(edges)

    default = subprocess.run([a.ld, '--verbose', '-m' + a.emulation], capture_output=True, text=True,
                             check=True).stdout
    script = default.split('=' * 50)
    if len(script) < 3:
        sys.exit('layout.py: cannot read the default linker script (ld --verbose)')
    script = script[1].strip('\n') + '\n'
    anchor = '    *(.text)\n    . = ALIGN(2);\n'
    if anchor not in script:
        sys.exit('layout.py: the default script has no `*(.text)` to anchor on')
    listed = ''.join(
        f'    {units[k][0]}\n' if units[k][0].startswith('*') else f'    *({units[k][0]})\n' for k in order)
    script = script.replace(anchor, anchor + listed, 1)
    with open(a.out, 'w') as f:
        f.write('/* Generated by firmware/layout.py from the first link: functions near their callees.\n'
                f'   Calls and jumps within RCALL reach: {before} -> {best} of {total}. */\n')
        f.write(script)
    print(f'layout.py: calls and jumps within reach {before} -> {best} of {total} ({len(units)} units)')


if __name__ == '__main__':
    main()
