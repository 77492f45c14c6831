#!/usr/bin/env python3
"""Function order for the firmware's second link: calls within reach of a 2-byte RCALL.

The AVR's CALL and JMP take 4 bytes; the linker's relaxation (--relax) turns them into 2-byte
RCALL/RJMP where the target lies within +-4 KB. In the default order the soft-float library
sits at the end of the 30 KB image, out of reach of most of its ~400 call sites. This script reads
a first link made without relaxation (with -ffunction-sections at link time, its map file and its
disassembly: every CALL/JMP still 4 bytes, every section its size before relaxation), orders the
sections so that callers lie near their callees, and writes a copy of the linker's default script
whose .text lists the sections in that order. The second link uses it; anything not listed (a
function renamed since) falls through to the script's usual `*(.text.*)`, so a stale order costs
bytes, never correctness.

Each section moves alone: the program's functions, and each member of the libraries (avr-libc's
soft-float and its other code, libgcc): between members they call and jump with relaxable CALL/JMP;
their RJMP/RCALL/branches stay inside a member (the libraries' relocations). Sections joined by
such a short branch all the same (none today) move together, in their first link's order.

The search (firmware/layout_anneal.cpp, a host program the build compiles first: simulated
annealing, many starts, the best kept) maximises the second link's calls in reach. Its exact
measure is the relaxation's fix point (a CALL made short moves everything after it by 2 bytes,
which brings others into reach), replayed on the first link's addresses; a RET after a jump,
which the relaxation deletes, is deleted too. This script replays the same relaxation on the
order it returns and keeps it only when the two agree (otherwise: the first link's order, bytes
lost, never correctness).

usage: layout.py --map first.map --elf first.elf --objdump avr-objdump --ld avr-ld
                 --emulation avr5 --anneal layout_anneal [--steps N --starts N] -o order.ld
"""
import argparse
import re
import subprocess
import sys

try:
    import numpy as np
except ImportError:
    np = None

# A CALL/JMP at `dot` becomes RCALL/RJMP when -4094 <= target - dot <= 4098 (binutils'
# elf32-avr.c, avr_relax_section: the 2-word reach, +2 forward because the deleted half lies
# between). Once relaxed, the displacement is target - (dot + 2) in [-4096, 4094].
GAP_LO, GAP_HI = -4094, 4098
SKIPS = ('sbic', 'sbis', 'sbrc', 'sbrs', 'cpse')


def text_from_map(path):
    """(input sections [(name, start, size, file)] placed in .text in address order, .text's end,
    the addresses of the global symbols)."""
    text = open(path).read()
    at = text.find('Linker script and memory map')
    if at < 0:
        sys.exit(f'{path}: no memory map')
    lines = text[at:].splitlines()
    out = []
    end = None
    pat_out = re.compile(r'^\.text\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)')
    pat_full = re.compile(r'^ (\.\S+)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$')
    pat_name = re.compile(r'^ (\.\S+)$')
    pat_rest = re.compile(r'^\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$')
    globals_ = set()
    i = 0
    inside = False  # in the .text output section's part of the map
    while i < len(lines):
        m = pat_out.match(lines[i])
        if m and end is None:
            end = int(m.group(1), 16) + int(m.group(2), 16)
            inside = True
        elif re.match(r'^\.\S', lines[i]):
            inside = False
        if not inside:
            i += 1
            continue
        g = re.match(r'^\s+0x([0-9a-f]+)\s+[A-Za-z_]\S*$', lines[i])
        if g:
            globals_.add(int(g.group(1), 16))
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
    if end is None:
        sys.exit(f'{path}: no .text output section')
    return sorted((s for s in out if s[2] > 0), key=lambda s: s[1]), end, globals_


def pattern_of(name, path):
    """The linker-script pattern that places this one input section, or None (fixed place)."""
    if not name.startswith('.text.'):
        return None  # vectors, progmem, init/fini, crt's .text: where the default script puts them
    m = re.match(r'.*/(lib[^/]+\.a)\(([^)]+)\)$', path)
    if m:  # a library member: its own object's section only
        return f'*{m.group(1)}:{m.group(2)}({name})'
    return f'*({name})'


def disassembly(elf, objdump):
    """[(address, size, mnemonic, target or None)] of every instruction, and the symbol addresses."""
    dis = subprocess.run([objdump, '-d', elf], capture_output=True, text=True, check=True).stdout
    insns, symbols = [], set()
    pat = re.compile(r'^\s*([0-9a-f]+):\s+((?:[0-9a-f]{2} )+)\s*(\S+)[^;]*(?:;\s*(?:0x([0-9a-f]+))?.*)?$')
    for line in dis.splitlines():
        m = re.match(r'^([0-9a-f]+) <[^>]+>:$', line)
        if m:
            symbols.add(int(m.group(1), 16))
            continue
        m = pat.match(line)
        if m:
            op = m.group(3)
            jumps = op in ('call', 'jmp', 'rcall', 'rjmp') or op.startswith('br')
            target = int(m.group(4), 16) if m.group(4) and jumps else None
            insns.append((int(m.group(1), 16), len(m.group(2).split()), op, target))
    return insns, symbols


class Layout:
    """The movable units, the call edges between them and the relaxation's fix point."""

    def __init__(self, secs, text_end, globals_, insns, symbols):
        movable = [s for s in secs if pattern_of(s[0], s[3])]
        if not movable:
            sys.exit('layout.py: no function sections in the map (link with -ffunction-sections)')
        first, last = movable[0][1], movable[-1][1] + movable[-1][2]
        if any(s[1] >= first and s[1] < last and not pattern_of(s[0], s[3]) for s in secs):
            sys.exit('layout.py: a fixed section among the function sections of the first link')
        # Sections by address; sections of one pattern (the same name in two objects) are one unit.
        unit_of_pattern = {}
        sec_unit = []
        for name, start, size, path in movable:
            p = pattern_of(name, path)
            sec_unit.append(unit_of_pattern.setdefault(p, len(unit_of_pattern)))
        starts = [s[1] for s in movable]

        def sec_at(addr):
            lo_, hi_ = 0, len(starts) - 1
            if addr < first or addr >= last:
                return None
            while lo_ < hi_:
                mid = (lo_ + hi_ + 1) // 2
                if starts[mid] <= addr:
                    lo_ = mid
                else:
                    hi_ = mid - 1
            return lo_

        # Fixed short branches (RJMP/RCALL/BRxx) between two units: those units move together.
        parent = list(range(len(unit_of_pattern)))

        def root(u):
            while parent[u] != u:
                parent[u] = parent[parent[u]]
                u = parent[u]
            return u

        for addr, size, op, target in insns:
            if target is None or op in ('call', 'jmp'):
                continue
            a, b = sec_at(addr), sec_at(target)
            if a is not None and b is not None and sec_unit[a] != sec_unit[b]:
                parent[root(sec_unit[a])] = root(sec_unit[b])
        # Units: [patterns], sections in first-link order; offsets as if placed one after another.
        groups = {}
        for k, (name, start, size, path) in enumerate(movable):
            groups.setdefault(root(sec_unit[k]), []).append(k)
        self.patterns, self.size = [], []
        sec_place = {}  # section -> (unit, offset of the section in the unit)
        # unit 0: everything before the movable sections (fixed); unit 1: everything after
        self.patterns += [None, None]
        self.size += [first, text_end - last]
        for g in sorted(groups.values(), key=lambda g: movable[g[0]][1]):
            u = len(self.size)
            off = 0
            pats = []
            for p in sorted({sec_unit[k] for k in g}):
                for k in g:
                    if sec_unit[k] == p:
                        sec_place[k] = (u, off)
                        off += movable[k][2]
                pats.append(next(pattern_of(movable[k][0], movable[k][3]) for k in g if sec_unit[k] == p))
            self.patterns.append(pats)
            self.size.append(off)

        def place(addr):
            """(unit, raw offset in it) of an address of .text."""
            if addr < first:
                return 0, addr
            if addr >= last:
                return 1, addr - last
            k = sec_at(addr)
            u, off = sec_place[k]
            return u, off + addr - movable[k][1]

        # Relaxable CALL/JMP (not the vector table's: relaxed there, they keep their 4 bytes),
        # and the RETs after a jump that the relaxation deletes (no label on them, no branch to
        # them, an instruction before the jump in its section and not a skip).
        vectors_end = next((s[1] + s[2] for s in secs if s[0] == '.vectors'), 0)
        branch_targets = {t for _, _, _, t in insns if t is not None}
        # A RET that ends its unit stays where a relocation of its object points at the next
        # section's start (the calls of a local function do, through the section's symbol):
        # deleted here unless the next unit is a local function of the same object (an
        # order-dependent deletion).
        section_starts = {s[1] for s in secs}
        unit_end = {}
        for k, (name, start, size, path) in enumerate(movable):
            u, off = sec_place[k]
            if off + size == self.size[u]:
                unit_end[start + size] = u
        self.obj = [None, None] + [movable[next(k for k in sec_place if sec_place[k][0] == u)][3]
                                   for u in range(2, len(self.size))]
        self.end_ret = [False] * len(self.size)
        self.local = [False, False] + [movable[next(k for k in sec_place if sec_place[k] == (u, 0))][1]
                                       not in globals_ for u in range(2, len(self.size))]
        edges, deleted = [], []
        prev = [None, None]
        for addr, size, op, target in insns:
            if addr >= text_end:
                break
            if op in ('call', 'jmp') and target is not None and addr >= vectors_end and target < text_end:
                edges.append(place(addr) + place(target))
            if (op == 'ret' and prev[1] and prev[1][2] in ('call', 'jmp', 'rcall', 'rjmp')
                    and prev[1][0] + prev[1][1] == addr and addr not in symbols
                    and addr not in branch_targets and prev[1][0] not in section_starts
                    and not (prev[0] and prev[0][2] in SKIPS)
                    and addr >= vectors_end):
                if addr + 2 in unit_end:
                    self.end_ret[unit_end[addr + 2]] = True
                else:
                    deleted.append(place(addr))
            prev = [prev[1], (addr, size, op, target)]
        self.n = len(self.size)
        self._arrays(edges, deleted)

    def _arrays(self, edges, deleted):
        n = self.n
        edges.sort(key=lambda e: (e[0], e[1]))
        E = len(edges)
        self.E = E
        self.cu = np.array([e[0] for e in edges], dtype=np.int64)
        self.co = np.array([e[1] for e in edges], dtype=np.int64)
        self.tu = np.array([e[2] for e in edges], dtype=np.int64)
        self.to = np.array([e[3] for e in edges], dtype=np.int64)
        self.raw = np.array(self.size, dtype=np.int64)
        # RETs deleted whatever the order: fewer bytes in their unit, before later offsets.
        dels = sorted(deleted)
        self.raw_eff = self.raw.copy()
        for u, _ in dels:
            self.raw_eff[u] -= 2

        def dels_before(u, off):
            return sum(1 for du, do in dels if du == u and do < off)
        self.co_fix = self.co - 2 * np.array([dels_before(u, o) for u, o in zip(self.cu, self.co)], dtype=np.int64)
        self.to_fix = self.to - 2 * np.array([dels_before(u, o) for u, o in zip(self.tu, self.to)], dtype=np.int64)
        # Edge blocks per calling unit (edges sorted by unit, offset): start index of each unit's
        # block; for each edge's target, the index of the first site of its unit at or after it.
        self.gstart = np.searchsorted(self.cu, np.arange(n), side='left')
        self.gend = np.searchsorted(self.cu, np.arange(n), side='right')
        keys = self.cu * (1 << 20) + self.co
        self.tidx = np.searchsorted(keys, self.tu * (1 << 20) + self.to, side='left')
        self.cross = self.cu != self.tu
        self.end_ret = np.array(self.end_ret)
        self.local = np.array(self.local)
        objs = {o: i for i, o in enumerate(set(self.obj))}
        self.obj_id = np.array([objs[o] for o in self.obj])

    def relax(self, order):
        """The second link's relaxation of this order: (relaxed edges, unit sizes, the addresses of
        the call sites, of their targets)."""
        o = np.array(order)
        nxt = np.empty(self.n, dtype=np.int64)
        nxt[o[:-1]] = o[1:]
        nxt[o[-1]] = o[-1]
        kept = (self.obj_id[nxt] == self.obj_id) & self.local[nxt]
        raw = self.raw_eff - 2 * (self.end_ret & ~kept)
        R = np.zeros(self.E, dtype=bool)
        while True:
            cs = np.concatenate(([0], np.cumsum(R)))
            size = raw - 2 * (cs[self.gend] - cs[self.gstart])
            pos = np.empty(self.n, dtype=np.int64)
            pos[o] = np.cumsum(size[o]) - size[o]
            idx = np.arange(self.E)
            site = pos[self.cu] + self.co_fix - 2 * (cs[idx] - cs[self.gstart[self.cu]])
            tgt = pos[self.tu] + self.to_fix - 2 * (cs[self.tidx] - cs[self.gstart[self.tu]])
            gap = tgt - site
            new = R | ((gap >= GAP_LO) & (gap <= GAP_HI))
            if (new == R).all():
                return R, size, site, tgt
            R = new


def problem_text(lay, order):
    """The search problem as firmware/layout_anneal.cpp reads it (its header comment)."""
    rows = [f'{lay.n} {lay.E} {len(order)}']
    for arr in (lay.raw_eff, lay.end_ret.astype(int), lay.local.astype(int), lay.obj_id, lay.cu,
                lay.co_fix, lay.tu, lay.to_fix, lay.tidx, lay.gstart, lay.gend, order):
        rows.append(' '.join(str(int(x)) for x in arr))
    return '\n'.join(rows) + '\n'


def search(lay, order, exe, steps, starts):
    """The order firmware/layout_anneal.cpp finds, or None (it failed, or its order's size is not
    the one this script's replay gives: a disagreement between the two replays)."""
    try:
        r = subprocess.run([exe, str(steps), str(starts), '12'], input=problem_text(lay, order),
                           capture_output=True, text=True, check=True, timeout=600)
        lines = r.stdout.split('\n')
        found, size = [int(x) for x in lines[0].split()], int(lines[1])
    except (OSError, subprocess.SubprocessError, ValueError, IndexError) as e:
        print(f'layout.py: {exe} failed ({e})')
        return None
    if sorted(found) != sorted(order) or found[0] != order[0] or found[-1] != order[-1]:
        print(f'layout.py: {exe} returned no permutation of the units')
        return None
    if exact(lay, found)[1] != size:
        print(f'layout.py: {exe} says {size} B, the replay here {exact(lay, found)[1]} B')
        return None
    return found


def exact(lay, order):
    R, size, _, _ = lay.relax(order)
    return int(np.count_nonzero(R & lay.cross)), int(size.sum())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--map', required=True)
    ap.add_argument('--elf', required=True)
    ap.add_argument('--objdump', default='avr-objdump')
    ap.add_argument('--ld', default='avr-ld')
    ap.add_argument('--emulation', default='avr5')
    ap.add_argument('--anneal', required=True, help='firmware/layout_anneal.cpp built: the search')
    ap.add_argument('--steps', type=int, default=200000, help='annealing steps per start')
    ap.add_argument('--starts', type=int, default=24, help='annealing runs, the best kept')
    ap.add_argument('--check', action='store_true',
                    help='exit 1 unless the search ran, agreed with the replay here and found an '
                         'order no larger than the first link\'s, and refused two malformed problems '
                         '(CTest avr_layout_anneal)')
    ap.add_argument('-o', '--out', required=True)
    a = ap.parse_args()

    default = subprocess.run([a.ld, '--verbose', '-m' + a.emulation], capture_output=True, text=True,
                             check=True).stdout
    script = default.split('=' * 50)
    if len(script) < 3:
        sys.exit('layout.py: cannot read the default linker script (ld --verbose)')
    script = script[1].strip('\n') + '\n'
    anchor = '    *(.text)\n    . = ALIGN(2);\n'
    if anchor not in script:
        sys.exit('layout.py: the default script has no `*(.text)` to anchor on')

    if np is None:  # no order: the second link is the default one (bytes lost, nothing wrong)
        with open(a.out, 'w') as f:
            f.write('/* firmware/layout.py: numpy missing, the default order. */\n' + script)
        print('layout.py: numpy not found: default order')
        return

    secs, text_end, globals_ = text_from_map(a.map)
    insns, symbols = disassembly(a.elf, a.objdump)
    lay = Layout(secs, text_end, globals_, insns, symbols)
    first = [0] + list(range(2, lay.n)) + [1]
    order = search(lay, first, a.anneal, a.steps, a.starts)
    if a.check:
        ok = order is not None and exact(lay, order)[1] <= exact(lay, first)[1]
        # A problem cut short and an order with a unit twice are refused (exit 2, no order).
        text = problem_text(lay, first)
        twice = first[:-1] + [first[1]]
        for bad in (text[:len(text) // 2], problem_text(lay, twice)):
            r = subprocess.run([a.anneal, '10', '1', '12'], input=bad, capture_output=True, text=True)
            ok = ok and r.returncode == 2 and r.stdout == ''

        print('layout.py --check: %s' % ('the search agrees with the replay here, %d -> %d B'
                                          % (exact(lay, first)[1], exact(lay, order)[1]) if ok else 'FAILED'))
        sys.exit(0 if ok else 1)
    if order is None:  # the first link's order: bytes lost (the budgets say so), nothing wrong
        print('layout.py: no search: the first link\'s order')
        order = first
    (before, size_before), (after, size_after) = exact(lay, first), exact(lay, order)
    total = int(np.count_nonzero(lay.cross))

    listed = ''.join(f'    {p}\n' for k in order[1:-1] for p in lay.patterns[k])
    script = script.replace(anchor, anchor + listed, 1)
    note = (f'calls and jumps within reach {before} -> {after} of {total} ({lay.n - 2} units), '
            f'.text {size_before} -> {size_after} B; {a.starts} x {a.steps} annealing steps')
    with open(a.out, 'w') as f:
        f.write('/* Generated by firmware/layout.py from the first link: functions near their callees.\n'
                f'   {note} (the relaxation replayed). */\n')
        f.write(script)
    print(f'layout.py: {note}')


if __name__ == '__main__':
    main()
