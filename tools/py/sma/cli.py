"""`sma` (pip install ./tools) or `tools/sma`: one entry point for the host tools.

  sma build                      build the C++ helpers (done automatically on first use)
  sma sim ...                    simulated rig -> rig log (sma_sim; `sma sim --help`)
  sma fit LOG.csv --out DIR      identification (sma_fit; its options pass through) + plots like Fig. 5-6
  sma plot LOG.csv --out DIR     any rig log to PNG, with the model's temperature
  sma discrepancy LOG.csv --out DIR   missing effects of the model (sma_discrepancy)
  sma console --port PORT        the board's serial console: commands, status, recording
  sma upload PARAMS.json --port PORT   model parameters into the board's EEPROM, verified
  sma dashboard --port PORT      the rig live in the browser (or --vrig: the firmware in the virtual rig)
  sma download --port PORT -o F.json  the board's active model as a params JSON
"""
import argparse
import os
import subprocess
import sys
import tempfile

from . import build as buildmod

EPILOG = """examples:
  tools/sma sim --volt train --params wire.json --noise 0.002 --out train.csv
  tools/sma fit train.csv --out fit/ --validate check.csv
  tools/sma plot run.csv --params fit/params.json --out plots/
  tools/sma console --port /dev/ttyACM0 --send "tele on" --send step --duration 160 --record run.csv
"""


def _tool(name):
    try:
        return buildmod.tool(name)
    except buildmod.BuildError as e:
        sys.stderr.write("sma: %s\n" % e)
        sys.exit(2)


def cmd_upload(args):
    from . import upload

    return upload.run(args)


def cmd_download(args):
    from . import download

    return download.run(args)


def cmd_build(args):
    try:
        d = buildmod.build(force=args.force)
    except buildmod.BuildError as e:
        sys.stderr.write("sma: %s\n" % e)
        return 2
    print("sma: helpers in %s" % d)
    return 0


def cmd_sim(args, rest):
    return subprocess.call([_tool("sma_sim")] + rest)


def cmd_discrepancy(rest):
    if "-h" in rest or "--help" in rest:
        return subprocess.call([_tool("sma_discrepancy")] + rest)
    from . import progress

    return progress.run_helper([_tool("sma_discrepancy")] + rest, "sma discrepancy")


def _own_options(prog, argv, own):
    """Splits argv into this command's own options (parsed) and the rest, passed verbatim to the
    C++ helper: its options are declared once, in the helper."""
    p = argparse.ArgumentParser(prog=prog, add_help=False, allow_abbrev=False)
    for args, kw in own:
        p.add_argument(*args, **kw)
    return p.parse_known_args(argv)


FIT_OWN = ((("--out",), {}), (("--no-plots",), {"action": "store_true"}))


def cmd_fit(argv):
    """sma fit LOG.csv [--params START.json] --out DIR [sma_fit options] [--no-plots]"""
    own, rest = _own_options("sma fit", argv, FIT_OWN)
    if not argv or "-h" in rest or "--help" in rest:
        subprocess.call([_tool("sma_fit"), "--help"])
        print("\nsma fit adds: --no-plots  skip the PNGs (training_time.png, fit_fraction.png "
              "like Fig. 5, fit_displacement.png like Fig. 6)")
        return 0 if argv else 2
    cmd = [_tool("sma_fit")] + rest + (["--out", own.out] if own.out else [])
    from . import progress

    rc = progress.run_helper(cmd, "sma fit")
    if rc != 0:
        return rc
    if own.out and not own.no_plots:
        from . import plot

        for p in plot.plot_fit(own.out):
            print("  plot " + p)
    return 0


PLOT_OWN = ((("log",), {"nargs": "?"}), (("--out",), {}))
PLOT_HELP = """usage: sma plot LOG.csv --out DIR [sma_sim replay options: --params P.json, --eps0 X, --tare, ...]

Plots a rig log (PNG): position, reference, error, voltage, displacement vs the model's
temperature. The model's run comes from `sma_sim --replay LOG` (its options pass through).
"""


def cmd_plot(argv):
    own, rest = _own_options("sma plot", argv, PLOT_OWN)
    if not argv or "-h" in rest or "--help" in rest:
        print(PLOT_HELP)
        return 0 if argv else 2
    if not own.log or not own.out:
        sys.stderr.write("sma plot: needs LOG.csv and --out DIR\n" + PLOT_HELP)
        return 2
    os.makedirs(own.out, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        replay = os.path.join(tmp, "replay.csv")
        rc = subprocess.call([_tool("sma_sim"), "--replay", own.log, "--out", replay] + rest)
        if rc != 0:
            return rc
        from . import plot

        title = os.path.basename(own.log)
        for p in plot.plot_log(replay, own.out, title):
            print("  plot " + p)
    return 0


def cmd_dashboard(args):
    from . import dashboard

    return dashboard.run(args)


def cmd_console(args):
    from . import console

    return console.run(args)


LINK_EXITS = "2 port, 3 link lost, 4 no reply."  # console.board_exchange


def _board_link(parser, port_help, timeout_help):
    """--port, --baud, --timeout: the serial link of the commands that talk to the board."""
    parser.add_argument("--port", required=True, help=port_help)
    parser.add_argument("--baud", type=int, default=115200)
    parser.add_argument("--timeout", type=float, default=2.0, help=timeout_help)


def make_parser():
    p = argparse.ArgumentParser(prog="sma", description=__doc__, epilog=EPILOG,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    b = sub.add_parser("build", help="build the C++ helpers (sma_sim, sma_fit)")
    b.add_argument("--force", action="store_true", help="re-run the CMake configuration")

    sub.add_parser("sim", add_help=False,
                   help="run the simulated rig, write a rig log (all options: sma sim --help)")
    sub.add_parser("discrepancy", add_help=False,
                   help="find, name and fit the effects the model misses in a log "
                        "(LOG.csv [--params P.json] --out DIR; all options: sma discrepancy --help)")

    sub.add_parser("fit", add_help=False,
                   help="identify the model from training log(s) (paper III.B; LOG.csv [--params START.json] "
                        "--out DIR; all options: sma fit --help)")
    sub.add_parser("plot", add_help=False,
                   help="plot a rig log (PNG) with the model's temperature (LOG.csv --out DIR [--params P.json])")

    c = sub.add_parser("console", help="serial console of the board: commands, live status, recording",
                       description="Connects to the board (or a pseudo-terminal, or a pyserial URL such "
                                   "as loop://), sends commands and waits for their OK/ERR, shows live "
                                   "status lines from the telemetry, records it as a rig log, and sends "
                                   "'stop' on Ctrl-C, at the end (unless --no-stop) and when the link is lost.")
    _board_link(c, "serial port, e.g. /dev/ttyACM0, /dev/pts/3, loop://", "reply timeout (s)")
    c.add_argument("--send", action="append", metavar="CMD",
                   help="command to send first (repeatable), e.g. --send 'tele on' --send 'pos 0.4'")
    c.add_argument("--record", metavar="FILE.csv", help="record the telemetry rows to a rig log")
    c.add_argument("--duration", type=float, help="keep the link open this many seconds, then stop")
    c.add_argument("--until", metavar="TEXT",
                   help="keep the link open until a line containing TEXT arrives, e.g. 'train done' "
                        "(--duration then bounds the wait: exit 5 if it passes first)")
    c.add_argument("-i", "--interactive", action="store_true", help="read commands from stdin")
    c.add_argument("--status", type=float, default=1.0, metavar="S",
                   help="status line period (s), 0 = none (default 1)")
    c.add_argument("--progress", type=float, metavar="S",
                   help="the run takes S seconds of board time (e.g. a training run): show a bar with "
                        "the time left (a terminal) or a line every 10 s (a log) instead of status lines")
    c.add_argument("--no-stop", action="store_true", help="do not send stop on a normal exit")
    c.add_argument("-q", "--quiet", action="store_true", help="do not echo replies")

    u = sub.add_parser("upload", help="model parameters (params JSON) into the board's EEPROM, verified",
                       description="Reads PARAMS.json (interfaces.md; the same reader as fit/sim: unknown "
                                   "keys or a non-physical set are refused before anything is sent), "
                                   "sends pbegin, pset for every key, pcommit, then reads every key "
                                   "back with pget. Any ERR or mismatch before the commit sends pabort: "
                                   "the board keeps its old set. The heater must be off (see --stop). "
                                   "Exit codes: 0 ok, 1 bad file/ERR/mismatch, " + LINK_EXITS)
    u.add_argument("params", metavar="PARAMS.json")
    _board_link(u, "serial port, e.g. /dev/ttyACM0, /tmp/simavr-uart0", "reply timeout (s) of pget/pinfo")
    u.add_argument("--stop", action="store_true", help="send stop first (heater off)")

    from . import dashboard

    dashboard.add_parser(sub)

    dl = sub.add_parser("download", help="the board's active model as a params JSON (restore with upload)",
                        description="Reads every key of the board's active model with pget (the stored "
                                    "float32 bits, exactly) and writes it as a params JSON (interfaces.md), "
                                    "which `sma upload` restores. Exit codes: 0 ok, 1 ERR/bad answer/bad set, "
                                    + LINK_EXITS)
    _board_link(dl, "serial port, e.g. /dev/ttyACM0, /tmp/simavr-uart0", "reply timeout (s)")
    dl.add_argument("-o", "--output", required=True, metavar="FILE.json")
    return p


PASS_THROUGH = {"fit": cmd_fit, "plot": cmd_plot}


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    p = make_parser()
    if argv and argv[0] == "sim":
        return cmd_sim(None, argv[1:] or ["--help"])
    if argv and argv[0] == "discrepancy":
        return cmd_discrepancy(argv[1:] or ["--help"])
    if argv and argv[0] in PASS_THROUGH:
        return PASS_THROUGH[argv[0]](argv[1:])
    args = p.parse_args(argv)
    if args.command is None:
        p.print_help()
        return 2
    return {"build": cmd_build, "console": cmd_console, "dashboard": cmd_dashboard,
            "upload": cmd_upload, "download": cmd_download}[args.command](args)
