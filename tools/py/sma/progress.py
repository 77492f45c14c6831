"""Progress of long runs: a bar with the time left on a terminal, plain lines in a log.

    with Progress("fit", total=400) as p:
        for i in ...:
            p.update(i + 1)

On a terminal (isatty) one line is redrawn in place: `fit [#####.....] 120/400 30% 0:12 left`;
otherwise a plain line is written at most every `every` seconds and at the end, so CI logs stay
short. The C++ helpers report with lines `progress: <i>/<n> [text]` on stderr
(host/include/sma_host/progress.hpp; they print them when SMA_PROGRESS=1, which run_helper sets);
`relay()` turns such a stream into this display, one bar per phase (a new bar when the count
goes back or the total changes: the fit's stage 1 then its main run, the discrepancy's rounds),
and passes every other line through.
"""
import os
import re
import sys
import time

PROGRESS_LINE = re.compile(r"^(?:\x1b\[K)?progress:\s*(\d+(?:\.\d+)?)\s*/\s*(\d+(?:\.\d+)?)\s*(.*)$")


def _clock(s):
    s = max(0, int(round(s)))
    return "%d:%02d:%02d" % (s // 3600, s // 60 % 60, s % 60) if s >= 3600 else "%d:%02d" % (s // 60, s % 60)


class Progress:
    def __init__(self, label, total=None, stream=None, every=10.0, width=30, tty=None, clock=time.monotonic):
        self.label = label
        self.total = total
        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty() if tty is None else tty
        self.every = every
        self.width = width
        self.clock = clock
        self.start = clock()
        self.done = 0
        self.text = ""
        self._last_print = None
        self._drawn = False
        self._printed = None

    def eta(self):
        """Seconds left by a straight line through the progress so far, or None."""
        if not self.total or self.done <= 0:
            return None
        elapsed = self.clock() - self.start
        return elapsed * (self.total - self.done) / self.done

    def line(self):
        elapsed = self.clock() - self.start
        parts = [self.label]
        if self.total:
            frac = min(1.0, self.done / self.total)
            if self.tty:
                n = int(frac * self.width)
                parts.append("[" + "#" * n + "." * (self.width - n) + "]")
            parts.append("%g/%g %3.0f%%" % (self.done, self.total, 100 * frac))
            left = self.eta()
            parts.append("%s elapsed" % _clock(elapsed))
            if left is not None and self.done < self.total:
                parts.append("%s left" % _clock(left))
        else:
            parts.append("%g, %s elapsed" % (self.done, _clock(elapsed)))
        if self.text:
            parts.append(self.text)
        return " ".join(parts)

    def update(self, done, text=None, total=None):
        self.done = done
        if total is not None:
            self.total = total
        if text is not None:
            self.text = text
        now = self.clock()
        if self.tty:
            if self._last_print is None or now - self._last_print >= 0.1:
                self.stream.write("\r\x1b[K" + self.line())
                self.stream.flush()
                self._drawn = True
                self._last_print = now
        elif self._last_print is None or now - self._last_print >= self.every:
            self._printed = self.line()
            self.stream.write(self._printed + "\n")
            self.stream.flush()
            self._last_print = now

    def message(self, text):
        """A line of other output that must not be drawn over."""
        if self.tty and self._drawn:
            self.stream.write("\r\x1b[K")
        self.stream.write(text.rstrip("\n") + "\n")
        self._drawn = False
        self._printed = None
        self._last_print = None if self.tty else self._last_print
        self.stream.flush()

    def finish(self):
        if self.tty:
            self.stream.write("\r\x1b[K" + self.line() + "\n")
        elif self.line() != self._printed:
            self.stream.write(self.line() + "\n")
        self.stream.flush()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.finish()


def relay(label, lines, stream=None, tty=None):
    """Renders `progress: i/n` lines of a helper's stderr (an iterable of lines) as a Progress
    and writes every other line through; returns the Progress (None if none was seen)."""
    p = None
    out = stream or sys.stderr
    for raw in lines:
        m = PROGRESS_LINE.match(raw.strip())
        if m:
            done, total = float(m.group(1)), float(m.group(2))
            if p is not None and (done < p.done or total != p.total):
                p.finish()  # the helper's next phase: its own bar and estimate
                p = None
            if p is None:
                p = Progress(label, stream=out, tty=tty)
            p.update(done, text=m.group(3) or None, total=total)
        elif p is not None:
            p.message(raw)
        else:
            out.write(raw if raw.endswith("\n") else raw + "\n")
            out.flush()
    if p is not None:
        p.finish()
    return p


def run_helper(cmd, label):
    """Runs a C++ helper, its stdout through, its stderr through relay(); returns the exit code."""
    import subprocess

    env = dict(os.environ, SMA_PROGRESS="1")
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, bufsize=1, env=env)
    relay(label, proc.stderr)
    return proc.wait()
