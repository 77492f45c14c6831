"""`pip install ./tools` into a fresh virtual environment gives a working `sma` command."""
import os
import subprocess
import sys

import pytest

from conftest import TOOLS

ROOT = os.path.dirname(TOOLS)


@pytest.fixture(scope="module")
def venv_sma(tmp_path_factory):
    venv = tmp_path_factory.mktemp("venv")
    r = subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip("python3 -m venv unavailable: %s" % r.stderr.strip()[-300:])
    py = str(venv / "bin" / "python")
    # The system's setuptools and wheel (scripts/setup) build it offline; numpy, matplotlib and
    # pyserial come from the system site packages.
    args = [py, "-m", "pip", "install", "-q", "--no-deps", TOOLS]
    try:
        import wheel  # noqa: F401
        args.insert(5, "--no-build-isolation")
    except ImportError:
        pass
    r = subprocess.run(args, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    sma = str(venv / "bin" / "sma")
    assert os.path.isfile(sma), "pip install gave no sma command"
    return sma


def test_installed_sma_has_every_subcommand(venv_sma, tmp_path):
    from sma import cli

    r = subprocess.run([venv_sma, "--help"], capture_output=True, text=True, cwd=str(tmp_path))
    assert r.returncode == 0, r.stderr
    sub = [a for a in cli.make_parser()._subparsers._group_actions][0]
    names = list(sub.choices)
    assert {"build", "sim", "fit", "plot", "discrepancy", "console", "upload"} <= set(names)
    for name in names:
        assert name in r.stdout, name


def test_installed_sma_is_the_package_not_the_source_tree(venv_sma, tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "SMA_ROOT")}
    r = subprocess.run([os.path.join(os.path.dirname(venv_sma), "python"), "-c",
                        "import sma, os; print(os.path.dirname(sma.__file__))"],
                       capture_output=True, text=True, cwd=str(tmp_path), env=env)
    assert r.returncode == 0, r.stderr
    pkg = r.stdout.strip()
    assert not pkg.startswith(ROOT), pkg
    for page in ("index.html", "app.js", "style.css"):  # the dashboard's page, served locally
        assert os.path.isfile(os.path.join(pkg, "web", page)), page


def test_installed_sma_outside_a_clone_says_where_the_helpers_come_from(venv_sma, tmp_path):
    env = {k: v for k, v in os.environ.items()
           if k not in ("SMA_FIT", "SMA_SIM", "SMA_ROOT", "SMA_BUILD_DIR", "PYTHONPATH")}
    env["PATH"] = "/usr/bin:/bin"
    (tmp_path / "log.csv").write_text("t_s,v_V,d_mm\n0,0,0\n")
    r = subprocess.run([venv_sma, "fit", "log.csv", "--out", "o"], capture_output=True, text=True,
                       cwd=str(tmp_path), env=env)
    assert r.returncode == 2
    assert "cannot find the C++ helper sma_fit" in r.stderr and "SMA_ROOT" in r.stderr, r.stderr


def test_installed_sma_runs_the_helpers_inside_a_clone(venv_sma, binaries, tmp_path):
    # $SMA_SIM (the build under test) is used; the command runs from the installed package.
    out = tmp_path / "s.csv"
    r = subprocess.run([venv_sma, "sim", "--volt", "const:0.5", "--duration", "2", "--out", str(out)],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    from sma import riglog

    log = riglog.read(str(out))
    assert len(log) > 10 and log["t_s"][-1] > 1.5
