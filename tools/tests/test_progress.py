"""sma.progress: a bar with the time left on a terminal, plain lines in a log."""
import io
import re

import pytest

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


def test_relay_starts_a_bar_per_phase_of_the_helper():
    out = io.StringIO()
    lines = ["progress: 10/60 fit stage 1\n", "progress: 60/60 fit stage 1\n",
             "progress: 3/45 fit\n", "progress: 45/45 fit\n"]
    p = progress.relay("sma fit", lines, stream=out, tty=False)
    text = out.getvalue().splitlines()
    assert p.total == 45 and p.done == 45
    assert any("60/60" in t and "stage 1" in t for t in text)  # stage 1 ended before the fit began
    assert text[-1].startswith("sma fit 45/45 100%")


def test_discrepancy_reports_its_candidates_per_round(binaries, tmp_path):
    """sma_discrepancy prints `progress: i/n` per candidate fitted (sma_host/progress.hpp, one
    bar per round); `sma discrepancy` renders them and passes its other lines through."""
    from conftest import run_sma

    log = tmp_path / "lh.csv"
    run_sma("sim", "--volt", "steps:1.7@0,1.3@30,0@60,1.5@90", "--duration", "120", "--dt", "0.1",
            "--noise", "0.002", "--seed", "4", "--effect", "latent_heat.L_J=1.5", "--out", log)
    r = run_sma("discrepancy", log, "--out", tmp_path / "d", "--no-plots")
    lines = r.stderr.splitlines()
    assert not [s for s in lines if s.startswith("progress:")]
    bars = [s for s in lines if s.startswith("sma discrepancy ") and "round 1" in s]
    assert bars and re.search(r"^discrepancy: \d+ samples", r.stderr, re.M)  # its own lines pass through
    done, total = map(float, bars[-1].split()[2].split("/"))
    assert done == total >= 1  # every candidate of round 1 fitted


def test_vrig_reports_simulated_seconds_only_when_asked(tmp_path):
    """vrig --quiet --duration S prints `progress: t/S` (simulated seconds) with SMA_PROGRESS=1,
    and nothing in a pipe without it (scripts that read its stderr see what they saw before)."""
    import os
    import subprocess

    from sma import build

    elf = os.path.join(build.build_dir(), "firmware", "sma_firmware.elf")
    try:
        vrig = build.tool("vrig")
    except build.BuildError as e:
        pytest.skip("no virtual rig: %s" % e)
    if not os.path.exists(elf):
        pytest.skip("no firmware ELF")
    script = tmp_path / "none.txt"
    script.write_text("")
    cmd = [vrig, elf, "--quiet", "--duration", "2", "--script", str(script)]
    env = dict(os.environ, SMA_PROGRESS="1")
    on = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert on.returncode == 0, on.stderr
    got = [m for m in (progress.PROGRESS_LINE.match(s) for s in on.stderr.splitlines()) if m]
    assert got and float(got[-1].group(1)) == float(got[-1].group(2)) == 2.0
    assert all(0 <= float(m.group(1)) <= 2.0 for m in got)
    env["SMA_PROGRESS"] = "0"
    off = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert off.returncode == 0 and "progress:" not in off.stderr
