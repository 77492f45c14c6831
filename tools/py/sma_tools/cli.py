"""`tools/sma`: one entry point for the host tools.

  sma build                      build the C++ helpers (done automatically on first use)
  sma sim ...                    simulated rig -> rig log (sma_sim; `sma sim --help`)
  sma fit LOG.csv --out DIR      identification (sma_fit) + plots like the paper's Fig. 5-6
  sma plot LOG.csv --out DIR     any rig log to PNG, with the model's temperature
  sma discrepancy LOG.csv --out DIR   missing effects of the model (sma_discrepancy)
  sma console --port PORT        the board's serial console: commands, status, recording
  sma upload PARAMS.json --port PORT   model parameters into the board's EEPROM, verified
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
    return subprocess.call([_tool("sma_discrepancy")] + rest)


def cmd_fit(args):
    cmd = [_tool("sma_fit"), args.log, "--out", args.out]
    if args.params:
        cmd += ["--params", args.params]
    if args.validate:
        cmd += ["--validate", args.validate]
    for opt in ("fit", "fix", "max_points", "max_evals", "eps0", "max_bad"):
        v = getattr(args, opt)
        if v is not None:
            cmd += ["--" + opt.replace("_", "-"), str(v)]
    rc = subprocess.call(cmd)
    if rc != 0:
        return rc
    if not args.no_plots:
        from . import plot

        for p in plot.plot_fit(args.out):
            print("  plot " + p)
    return 0


def cmd_plot(args):
    os.makedirs(args.out, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        replay = os.path.join(tmp, "replay.csv")
        cmd = [_tool("sma_sim"), "--replay", args.log, "--out", replay]
        if args.params:
            cmd += ["--params", args.params]
        if args.eps0 is not None:
            cmd += ["--eps0", str(args.eps0)]
        if args.tare:
            cmd += ["--tare"]
        rc = subprocess.call(cmd)
        if rc != 0:
            return rc
        from . import plot

        title = os.path.basename(args.log)
        for p in plot.plot_log(replay, args.out, title):
            print("  plot " + p)
    return 0


def cmd_console(args):
    from . import console

    return console.run(args)


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

    f = sub.add_parser("fit", help="identify the model from a training log (paper III.B)",
                       description="Fits T_AS, T_AF, T_MF, q, e, T_MSs, T_MSf, the loops' j and T_ii, "
                                   "h, g and the sensor offset to a training log with Levenberg-Marquardt; "
                                   "writes DIR/params.json, fit.json, report.md and PNG plots.")
    f.add_argument("log", help="training rig log (t_s,v_V,d_mm,...)")
    f.add_argument("--out", required=True, help="output directory")
    f.add_argument("--params", help="start values / fixed parameters (JSON); default: the paper's")
    f.add_argument("--validate", help="a second log, not used for the fit")
    f.add_argument("--fit", help="comma list of parameters to fit (see sma_fit --help)")
    f.add_argument("--fix", help="comma list of parameters to keep at their start value")
    f.add_argument("--max-points", type=int, help="residual samples used (default 6000)")
    f.add_argument("--max-evals", type=int, help="budget of model runs (default 400)")
    f.add_argument("--eps0", type=float, help="austenite fraction at the start of the log")
    f.add_argument("--max-bad", type=float, help="refuse a log with more than this fraction of bad rows")
    f.add_argument("--no-plots", action="store_true", help="skip the PNGs")

    pl = sub.add_parser("plot", help="plot a rig log (PNG): position, reference, error, voltage, "
                                     "displacement vs the model's temperature")
    pl.add_argument("log", help="rig log CSV")
    pl.add_argument("--out", required=True, help="output directory")
    pl.add_argument("--params", help="model for the temperature (JSON); default: the paper's")
    pl.add_argument("--eps0", type=float, help="austenite fraction at the start of the log")
    pl.add_argument("--tare", action="store_true",
                    help="match the model's sensor zero to the log's first samples")

    c = sub.add_parser("console", help="serial console of the board: commands, live status, recording",
                       description="Connects to the board (or a pseudo-terminal, or a pyserial URL such "
                                   "as loop://), sends commands and waits for their OK/ERR, shows live "
                                   "status lines from the telemetry, records it as a rig log, and sends "
                                   "'stop' on Ctrl-C, at the end (unless --no-stop) and when the link is lost.")
    c.add_argument("--port", required=True, help="serial port, e.g. /dev/ttyACM0, /dev/pts/3, loop://")
    c.add_argument("--baud", type=int, default=115200)
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
    c.add_argument("--timeout", type=float, default=2.0, help="reply timeout (s)")
    c.add_argument("--no-stop", action="store_true", help="do not send stop on a normal exit")
    c.add_argument("-q", "--quiet", action="store_true", help="do not echo replies")

    u = sub.add_parser("upload", help="model parameters (params JSON) into the board's EEPROM, verified",
                       description="Reads PARAMS.json (interfaces.md; the same reader as fit/sim: unknown "
                                   "keys or a non-physical set are refused before anything is sent), "
                                   "sends pbegin, pset for every key, pcommit, then reads every key "
                                   "back with pget. Any ERR or mismatch before the commit sends pabort: "
                                   "the board keeps its old set. The heater must be off (see --stop). "
                                   "Exit codes: 0 ok, 1 bad file/ERR/mismatch, 2 port, 3 link lost, 4 no reply.")
    u.add_argument("params", metavar="PARAMS.json")
    u.add_argument("--port", required=True, help="serial port, e.g. /dev/ttyACM0, /tmp/simavr-uart0")
    u.add_argument("--baud", type=int, default=115200)
    u.add_argument("--timeout", type=float, default=2.0, help="reply timeout (s) of pget/pinfo")
    u.add_argument("--stop", action="store_true", help="send stop first (heater off)")
    dl = sub.add_parser("download", help="the board's active model as a params JSON (restore with upload)",
                        description="Reads every key of the board's active model with pget (the stored "
                                    "float32 bits, exactly) and writes it as a params JSON (interfaces.md), "
                                    "which `sma upload` restores. Exit codes: 0 ok, 1 ERR/bad answer/bad set, "
                                    "2 port, 3 link lost, 4 no reply.")
    dl.add_argument("--port", required=True, help="serial port, e.g. /dev/ttyACM0, /tmp/simavr-uart0")
    dl.add_argument("-o", "--output", required=True, metavar="FILE.json")
    dl.add_argument("--baud", type=int, default=115200)
    dl.add_argument("--timeout", type=float, default=2.0, help="reply timeout (s)")
    return p


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    p = make_parser()
    if argv and argv[0] == "sim":
        return cmd_sim(None, argv[1:] or ["--help"])
    if argv and argv[0] == "discrepancy":
        return cmd_discrepancy(argv[1:] or ["--help"])
    args = p.parse_args(argv)
    if args.command is None:
        p.print_help()
        return 2
    return {"build": cmd_build, "fit": cmd_fit, "plot": cmd_plot, "console": cmd_console,
            "upload": cmd_upload, "download": cmd_download}[args.command](args)
