"""The Python side's one reader of rig logs (interfaces.md) and of the helpers' CSV outputs.

Format: lines starting with '#' are comments, then a header line of column names, then one row
of numbers per sample. The C++ reader (tools/host/include/sma_tools/rig_log.hpp, fuzzed) is the
one the identification uses; this one serves plots, the virtual-rig scripts and the dashboard,
and reads a file as it does (interfaces.md: "the tool says how many it dropped or refuses the
file"): a bad row (wrong field count, text in a number, NaN, time going back) is dropped, listed
in `dropped` and warned about on stderr naming the file and line; the file is refused when more
than MAX_BAD_FRACTION of its rows (or MAX_BAD_ROWS) are bad (LogReadOptions of rig_log.hpp).
strict=True refuses the file at its first bad row (the helpers' own CSVs).
"""
import math
import sys

REQUIRED = ("t_s", "v_V", "d_mm")
MAX_BAD_FRACTION = 0.01  # as the C++ reader's LogReadOptions
MAX_BAD_ROWS = 1000
KEEP_PROBLEMS = 10       # problems listed in a message


class RigLogError(ValueError):
    pass


class RigLog:
    """columns: name -> numpy array; comments: text of the '#' lines; dropped: [(line, why)];
    rows_read: data rows seen (kept and dropped)."""

    def __init__(self, path, columns, comments, dropped, rows_read=0):
        self.path = path
        self.columns = columns
        self.comments = comments
        self.dropped = dropped
        self.rows_read = rows_read

    def __getitem__(self, name):
        try:
            return self.columns[name]
        except KeyError:
            raise RigLogError("%s: no column '%s' (has %s)" % (self.path, name, ", ".join(self.columns)))

    def __contains__(self, name):
        return name in self.columns

    def __len__(self):
        return len(next(iter(self.columns.values()))) if self.columns else 0

    def rows(self):
        """The samples as tuples in header order."""
        cols = list(self.columns.values())
        return [tuple(float(c[i]) for c in cols) for i in range(len(self))]


def parse_row(text, ncols):
    """-> tuple of finite floats, or raises ValueError saying why."""
    parts = text.split(",")
    if len(parts) != ncols:
        raise ValueError("%d fields, the header has %d" % (len(parts), ncols))
    vals = []
    for p in parts:
        try:
            v = float(p)
        except ValueError:
            raise ValueError("'%s' is not a number" % p.strip())
        if not math.isfinite(v):
            raise ValueError("'%s' is not finite" % p.strip())
        vals.append(v)
    return tuple(vals)


def describe(path, dropped, keep=KEEP_PROBLEMS):
    """The dropped rows as the C++ reader lists them: one 'path:line: why' a line."""
    out = "".join("\n  %s:%d: %s" % (path, line, why) for line, why in dropped[:keep])
    if len(dropped) > keep:
        out += "\n  ... and %d more" % (len(dropped) - keep)
    return out


def read(path, required=REQUIRED, strict=False, empty_ok=False, max_bad_fraction=MAX_BAD_FRACTION,
         max_bad_rows=MAX_BAD_ROWS):
    """Reads a CSV; `required` columns must be present (pass () for the helpers' CSVs).
    Bad rows are dropped with a warning, the file refused above max_bad_fraction / max_bad_rows;
    strict: refused at the first bad row.
    empty_ok: a file without a header (a run that never sent telemetry) is a log of no rows."""
    import numpy as np

    comments, header, rows, dropped = [], None, [], []
    rows_read = 0
    last_t = None
    t_index = None
    with open(path, encoding="utf-8-sig") as f:  # a spreadsheet's byte-order mark is not data
        for lineno, line in enumerate(f, 1):
            s = line.strip()
            if not s:
                continue
            if s.startswith("#"):
                comments.append(s[1:].strip())
                continue
            if header is None:
                header = [c.strip() for c in s.split(",")]
                missing = [c for c in required if c not in header]
                if missing:
                    raise RigLogError("%s:%d: header lacks the column(s) %s (header: %s)"
                                      % (path, lineno, ", ".join(missing), s))
                t_index = header.index("t_s") if "t_s" in header else None
                continue
            rows_read += 1
            try:
                vals = parse_row(s, len(header))
                if t_index is not None:
                    if last_t is not None and not vals[t_index] > last_t:
                        raise ValueError("time %g after %g: must increase" % (vals[t_index], last_t))
                    last_t = vals[t_index]
            except ValueError as e:
                if strict:
                    raise RigLogError("%s:%d: %s" % (path, lineno, e))
                dropped.append((lineno, str(e)))
                continue
            rows.append(vals)
    if header is None:
        if empty_ok:
            return RigLog(path, {}, comments, dropped)
        raise RigLogError("%s: no header line (expected e.g. t_s,v_V,d_mm)" % path)
    if dropped and (len(dropped) > max_bad_fraction * rows_read or len(dropped) > max_bad_rows):
        raise RigLogError("%s: refused: %d bad rows of %d (more than %d %%):%s"
                          % (path, len(dropped), rows_read, round(100 * max_bad_fraction), describe(path, dropped)))
    if dropped:
        sys.stderr.write("%s: dropped %d bad rows of %d:%s\n"
                         % (path, len(dropped), rows_read, describe(path, dropped, 5)))
    a = np.array(rows, dtype=float).reshape(-1, len(header))
    return RigLog(path, {name: a[:, i] for i, name in enumerate(header)}, comments, dropped, rows_read)


def load(path):
    """(columns, comments) of a helper's CSV (no required columns, strict)."""
    log = read(path, required=(), strict=True)
    return log.columns, log.comments
