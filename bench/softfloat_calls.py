#!/usr/bin/env python3
"""What an AVR image pays for its soft float, and who calls it (issue 12, item 4).

The soft-float members (avr-libc's libm: __addsf3 .. __fp_*) stay linked while any function of
the image calls one of them, so the Q16.16 image loses them (1078 B of libm's float sections)
only when its last caller goes. This prints, per ELF, the bytes of those sections (from the link
map next to the ELF) and every function that calls a member (avr-objdump -d: CALL/RCALL/JMP/RJMP
targets), with the calls per member, so that a step that removes a group of callers shows what
is left; --json also keeps each member's avr-nm size.

  python3 bench/softfloat_calls.py --build build [--json build/bench-results/softfloat.json]
"""
import argparse
import collections
import json
import os
import re
import subprocess
import sys

# avr-libc's soft-float entry points and helpers (libm/fplib), and the conversions.
MEMBER = re.compile(r"^__(?:(?:add|sub|mul|div)sf3x?|(?:cmp|eq|ne|lt|le|gt|ge|unord)sf2|"
                    r"fixu?n?s?sfsi|fixu?n?s?sfdi|floatu?n?s?sisf|floatu?n?s?disf|fp_\w+|"
                    r"(?:add|sub|mul|div)sf3_pse)$")
LABEL = re.compile(r"^([0-9a-f]+) <(.+)>:$")
CALL = re.compile(r"\s(?:call|rcall|jmp|rjmp)\s+[^<]*<([^>+]+)>")


def symbols(elf):
    """name -> (address, size) of every sized function."""
    out = subprocess.run(["avr-nm", "-S", elf], check=True, capture_output=True, text=True).stdout
    syms = {}
    for line in out.splitlines():
        f = line.split()
        if len(f) == 4 and f[2] in "tTwW":
            syms[f[3]] = (int(f[0], 16), int(f[1], 16))
    return syms


def linked_bytes(elf):
    """The libm float sections the linker kept (its map, when next to the ELF), or None.

    avr-nm's sizes of the assembly members overlap and miss unlabelled parts; the map does not."""
    for m in (elf + ".map", elf[:-4] + ".first.elf.map"):
        if os.path.exists(m):
            text = open(m).read()
            return sum(int(s, 16) for s in re.findall(r"\.text\.avr-libc\.fplib\s+0x[0-9a-f]+\s+(0x[0-9a-f]+)", text))
    return None


def callers(elf, soft, syms):
    dis = subprocess.run(["avr-objdump", "-d", elf], check=True, capture_output=True, text=True).stdout
    calls = collections.defaultdict(collections.Counter)
    cur = None
    for line in dis.splitlines():
        m = LABEL.match(line)
        if m:
            cur = m.group(2)
            start, size = syms.get(cur, (0, 1 << 20))
            continue
        # Past the end of its label's symbol: libm code that has no symbol of its own.
        addr = line.split(":", 1)[0].strip()
        if cur and re.fullmatch(r"[0-9a-f]+", addr) and int(addr, 16) >= start + size:
            cur = None
        m = CALL.search(line)
        if m and cur and not MEMBER.match(cur) and MEMBER.match(m.group(1)) and m.group(1) in soft:
            calls[cur][m.group(1)] += 1
    names = list(calls)
    dem = subprocess.run(["avr-c++filt"], input="\n".join(names), check=True, capture_output=True,
                         text=True).stdout.splitlines() if names else []
    return {d: dict(calls[n]) for n, d in zip(names, dem)}


def short(name):
    name = re.sub(r"sma::Board<[^>]*>", "Board", name)
    name = re.sub(r"<sma::Fixed>", "<Fixed>", name).replace("sma::", "")
    return name[:70]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--json")
    ap.add_argument("elves", nargs="*", help="default: the Uno images of --build")
    a = ap.parse_args()
    elves = a.elves or [os.path.join(a.build, "firmware", n + ".elf")
                        for n in ("sma_firmware_fixed", "sma_firmware")]
    result = {}
    for elf in elves:
        if not os.path.exists(elf):
            sys.exit(f"{elf}: not built")
        syms = symbols(elf)
        soft = {n: s for n, (a, s) in syms.items() if MEMBER.match(n)}
        who = callers(elf, soft, syms)
        name = os.path.splitext(os.path.basename(elf))[0]
        linked = linked_bytes(elf)
        result[name] = {"members": soft, "fplib_B": linked, "callers": who}
        print(f"\n{name}: {len(soft)} soft-float members, libm float sections {linked} B (map), "
              f"{len(who)} functions call them")
        print("| caller | calls | into |\n|---|---|---|")
        for c, ops in sorted(who.items(), key=lambda kv: -sum(kv[1].values())):
            into = ", ".join(f"{o.strip('_')} {n}" for o, n in sorted(ops.items(), key=lambda kv: -kv[1]))
            print(f"| `{short(c)}` | {sum(ops.values())} | {into} |")
    if a.json:
        os.makedirs(os.path.dirname(a.json) or ".", exist_ok=True)
        with open(a.json, "w") as f:
            json.dump(result, f, indent=1, sort_keys=True)


if __name__ == "__main__":
    main()
