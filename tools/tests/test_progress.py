"""sma.progress: a bar with the time left on a terminal, plain lines in a log."""
import io

from sma import progress


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


class Tty(io.StringIO):
    def isatty(self):
        return True


def test_terminal_bar_estimates_the_time_left():
    clk, out = Clock(), Tty()
    p = progress.Progress("fit", total=100, stream=out, clock=clk)
    clk.t = 30.0
    p.update(25)  # a quarter in 30 s: 90 s left at this pace
    line = out.getvalue().split("\r")[-1]
    assert "[#######" in line and "25/100" in line and "1:30 left" in line and "0:30 elapsed" in line
    p.finish()
    assert out.getvalue().endswith("\n")


def test_log_gets_plain_lines_at_most_every_period():
    clk, out = Clock(), io.StringIO()
    p = progress.Progress("train", total=10, stream=out, every=10.0, clock=clk)
    for i in range(1, 11):
        clk.t = 2.0 * i
        p.update(i)
    p.finish()
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue() and "[" not in out.getvalue()
    assert len(lines) == 3  # t = 2 (first), 12 (10 s later), the end
    assert lines[-1].startswith("train 10/10 100%")


def test_relay_renders_helper_progress_lines_and_passes_the_rest():
    out = io.StringIO()
    p = progress.relay("sma discrepancy", ["reading log\n", "progress: 1/4 candidate a\n", "warning: x\n",
                                           "progress: 4/4\n"], stream=out, tty=False)
    text = out.getvalue()
    assert p is not None and p.done == 4 and p.total == 4
    assert "reading log" in text and "warning: x" in text and "progress:" not in text
    assert "1/4" in text and "candidate a" in text
