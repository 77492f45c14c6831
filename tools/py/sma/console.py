"""Talks to the firmware's serial console (lib/sma_model/include/sma/console.hpp).

Protocol: one command per line (`pos 0.4`, `mode ffpid`, `step`, `sine`, `stop`, `tele on`, ...);
each command gets one reply line `OK ...` or `ERR ...`. With `tele on` the board sends the header
`t_s,v_V,d_mm,ref_mm,duty` once, then one row per tick; lines starting with '#' are comments.

The protocol handling (ConsoleClient) works on any object with `write(bytes)` and `read(n)`
(pyserial's Serial, or a fake in the tests); the I/O loop (run) adds stdin, status lines,
recording, and sends `stop` on Ctrl-C, at the end, and when the link is lost.
"""
import math
import re
import sys
import time

TELE_HEADER = "t_s,v_V,d_mm,ref_mm,duty"
TELE_COLUMNS = TELE_HEADER.split(",")


# A plotter line: Teleplot's `>name:value[|flags]` (or `>name:time_ms:value`), or the Arduino
# Serial Plotter's numbers, bare or `label:value`, separated by commas, spaces or tabs.
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_PLOTTER_FIELD = re.compile(r"^(?:[A-Za-z_][\w.\-]*:)?%s$" % _NUMBER)
PLOTTER_NOTE = ("the board streams plotter lines (Teleplot / Serial Plotter): ignored here; "
                "'tele on' gives the rig-log telemetry that is plotted and recorded")


def is_plotter_line(s):
    if s.startswith(">"):
        return True
    fields = [f for f in re.split(r"[,\s]+", s) if f]
    return bool(fields) and all(_PLOTTER_FIELD.match(f) for f in fields)


class LinkLost(Exception):
    pass


class CommandError(Exception):
    """The board answered ERR."""


def classify(line):
    """-> (kind, payload): 'reply' (ok: bool, text), 'header', 'row' (tuple of 5 floats),
    'comment' (text), 'empty', 'plotter' (text: a Teleplot / Serial Plotter line), or 'other'."""
    s = line.strip()
    if not s:
        return "empty", None
    if s.startswith("OK"):
        return "reply", (True, s)
    if s.startswith("ERR"):
        return "reply", (False, s)
    if s.startswith("#"):
        return "comment", s[1:].strip()
    if s.replace(" ", "") == TELE_HEADER:
        return "header", None
    parts = s.split(",")
    if len(parts) == 5:
        try:
            vals = tuple(float(p) for p in parts)
            if all(math.isfinite(v) for v in vals):
                return "row", vals
        except ValueError:
            pass
    if is_plotter_line(s):
        return "plotter", s
    return "other", s


class Recorder:
    """Writes telemetry rows as a rig log (interfaces.md): comments, header, rows."""

    def __init__(self, f, port_name):
        self.f = f
        self.rows = 0
        self.skipped = 0
        self._last_t = None
        f.write("# rig: recorded by tools/sma console from %s at %s\n" % (port_name, time.strftime("%Y-%m-%d %H:%M:%S")))
        f.write(TELE_HEADER + "\n")

    def comment(self, text):
        self.f.write("# %s\n" % text)

    def row(self, vals):
        # A board reset restarts the time: keep the log readable (time must increase).
        if self._last_t is not None and not vals[0] > self._last_t:
            self.skipped += 1
            self.comment("time went back from %.2f to %.2f (board reset?): row skipped" % (self._last_t, vals[0]))
            return
        self._last_t = vals[0]
        self.f.write("%s\n" % ",".join(_fmt(v) for v in vals))
        self.rows += 1

    def flush(self):
        self.f.flush()


def _fmt(v):
    s = "%.6f" % v
    return s.rstrip("0").rstrip(".") if "." in s else s


class ConsoleClient:
    def __init__(self, port, recorder=None, echo=None, clock=time.monotonic):
        self.port = port
        self.recorder = recorder
        self.echo = echo or (lambda text: None)  # replies, comments, other lines
        self.clock = clock
        self._buf = b""
        self.replies = []  # (ok, text) not yet consumed by send()
        self.last_row = None
        self.rows = 0
        self.other = 0
        self.plotter = 0  # Teleplot / Serial Plotter lines: counted, named once, not echoed
        self.until = None        # text awaited in a comment or other line (--until)
        self.until_seen = False

    # ---- input ------------------------------------------------------------------------------
    def _read(self, n=4096):
        try:
            data = self.port.read(n)
        except Exception as e:  # serial.SerialException, OSError: the link is gone
            raise LinkLost(str(e))
        return data or b""

    def feed(self, data):
        """Bytes in -> handled lines; returns the list of (kind, payload)."""
        self._buf += data
        out = []
        while True:
            i = min([p for p in (self._buf.find(b"\n"), self._buf.find(b"\r")) if p >= 0], default=-1)
            if i < 0:
                break
            raw, self._buf = self._buf[:i], self._buf[i + 1:]
            line = raw.decode("ascii", errors="replace")
            kind, payload = classify(line)
            if kind != "empty":
                self._handle(kind, payload)
                out.append((kind, payload))
        if len(self._buf) > 4096:  # no line end for a long time: garbage
            self._buf = b""
        return out

    def _handle(self, kind, payload):
        if kind == "reply":
            self.replies.append(payload)
            self.echo(payload[1])
        elif kind == "row":
            self.last_row = payload
            self.rows += 1
            if self.recorder:
                self.recorder.row(payload)
        elif kind == "comment":
            self.echo("# " + payload)
            if self.recorder:
                self.recorder.comment(payload)
        elif kind == "other":
            self.other += 1
            self.echo(payload)
        elif kind == "plotter":
            self.plotter += 1
            if self.plotter == 1:
                self.echo("(%s)" % PLOTTER_NOTE)
        if self.until and kind in ("comment", "other") and self.until in payload:
            self.until_seen = True

    def poll(self):
        """Reads what is there (the port's timeout bounds the wait); returns handled lines."""
        return self.feed(self._read())

    # ---- output -----------------------------------------------------------------------------
    def write_line(self, cmd):
        try:
            self.port.write((cmd.strip() + "\n").encode("ascii"))
            flush = getattr(self.port, "flush", None)
            if flush:
                flush()
        except Exception as e:
            raise LinkLost(str(e))

    def send(self, cmd, timeout=2.0, check=True):
        """Sends a command and waits for its OK/ERR reply; returns the reply text."""
        self.replies.clear()
        self.write_line(cmd)
        end = self.clock() + timeout
        while not self.replies:
            if self.clock() > end:
                raise TimeoutError("no reply to '%s' within %.1f s" % (cmd, timeout))
            self.poll()
        ok, text = self.replies.pop(0)
        if check and not ok:
            raise CommandError(text)
        return text

    def stop(self):
        """Heater off: best effort (the link may be gone)."""
        try:
            return self.send("stop", timeout=1.0, check=False)
        except (LinkLost, TimeoutError):
            return None

    def status_line(self):
        r = self.last_row
        if r is None:
            return "no telemetry (send 'tele on')"
        return "t=%8.2f s  d=%8.4f mm  ref=%8.4f mm  err=%+8.4f mm  V=%6.3f  duty=%.4f" % (
            r[0], r[2], r[3], r[3] - r[2], r[1], r[4])


def open_port(url, baud, prog, err, exclusive=True):
    """The serial port (a device, a pseudo-terminal or a pyserial URL such as loop://), or None
    after a message naming it; shared by `sma console`, `upload` and `dashboard`. A device is
    opened exclusively (flock): two of these tools never talk to one board at once."""
    import serial

    kw = {"exclusive": True} if exclusive and "://" not in url else {}
    try:
        return serial.serial_for_url(url, baudrate=baud, timeout=0.05, **kw)
    except (serial.SerialException, ValueError) as e:
        if "exclusively lock" in str(e):
            err.write("%s: cannot open %s: in use by another program (an sma dashboard? press "
                      "'Release port' on its page, or end it)\n" % (prog, url))
        else:
            err.write("%s: cannot open %s: %s\n" % (prog, url, e))
        return None


def params_helper(prog, err):
    """The sma_params helper (built or found), or None after a message."""
    from . import build

    try:
        return build.tool("sma_params")
    except build.BuildError as e:
        err.write("%s: %s\n" % (prog, e))
        return None


def board_exchange(prog, args, port, err, exchange, refused):
    """Opens args.port (unless `port` is given), runs exchange(ConsoleClient) and closes the port;
    the exit code of `sma upload` / `sma download`: 0 ok, 1 a `refused` exception (an ERR, a bad
    answer), 2 the port cannot be opened, 3 link lost, 4 no reply; each failure named on `err`."""
    if port is None:
        port = open_port(args.port, args.baud, prog, err)
        if port is None:
            return 2
    try:
        exchange(ConsoleClient(port))
        return 0
    except refused as e:
        err.write("%s: %s\n" % (prog, e))
        return 1
    except LinkLost as e:
        err.write("%s: link lost: %s\n" % (prog, e))
        return 3
    except TimeoutError as e:
        err.write("%s: %s\n" % (prog, e))
        return 4
    finally:
        close = getattr(port, "close", None)
        if close:
            close()


def run(args, port=None, stdin=None, out=sys.stdout, err=sys.stderr):
    """The `sma console` command. Returns the exit code: 0 ok, 1 ERR reply to a --send command,
    2 port cannot be opened, 3 link lost, 4 no reply, 5 --until text not seen within --duration,
    130 interrupted (after `stop` was sent)."""
    import queue
    import threading

    if port is None:
        port = open_port(args.port, args.baud, "sma console", err)
        if port is None:
            return 2
    rec_file = None
    recorder = None
    if args.record:
        rec_file = open(args.record, "w")
        recorder = Recorder(rec_file, args.port)
    echo = (lambda text: out.write(text + "\n")) if not args.quiet else None
    c = ConsoleClient(port, recorder=recorder, echo=echo)
    c.until = getattr(args, "until", None)
    lines = queue.Queue()
    if args.interactive:
        src = stdin or sys.stdin

        def reader():
            for line in src:
                lines.put(line)
            lines.put(None)

        threading.Thread(target=reader, daemon=True).start()
    code = 0
    bar = None
    try:
        for cmd in args.send or []:
            try:
                c.send(cmd, timeout=args.timeout)
            except CommandError as e:
                err.write("sma console: '%s' refused: %s\n" % (cmd, e))
                code = 1
                break
        start = time.monotonic()
        last_status = 0.0
        t_first = None
        if getattr(args, "progress", None):
            from . import progress

            bar = progress.Progress("board time s", total=args.progress, stream=err)
        while code == 0:
            now = time.monotonic()
            if c.until_seen:
                break
            if args.duration is not None and now - start >= args.duration:
                if c.until:
                    err.write("\nsma console: '%s' not seen within %g s\n" % (c.until, args.duration))
                    code = 5
                break
            if not args.interactive and args.duration is None and not c.until:
                break
            while not lines.empty():
                line = lines.get()
                if line is None:  # stdin closed
                    args.interactive = False
                    if args.duration is None:
                        args.duration = 0
                    break
                if line.strip():
                    c.write_line(line)
            c.poll()
            if bar is not None and c.last_row is not None:
                if t_first is None:
                    t_first = c.last_row[0]
                bar.update(round(c.last_row[0] - t_first, 1), text="d=%.4f mm V=%.3f" % (c.last_row[2], c.last_row[1]))
            elif args.status and c.last_row is not None and now - last_status >= args.status:
                err.write("\r" + c.status_line())
                err.flush()
                last_status = now
    except KeyboardInterrupt:
        err.write("\nsma console: interrupted, sending stop\n")
        code = 130
    except LinkLost as e:
        err.write("\nsma console: link lost (%s): heater state unknown, trying to send stop\n" % e)
        code = 3
    except TimeoutError as e:
        err.write("\nsma console: %s: is this the board's port, at %d baud?\n" % (e, args.baud))
        code = 4
    finally:
        if bar is not None:
            bar.finish()
        if not args.no_stop or code != 0:
            reply = c.stop()
            if reply is not None and not args.quiet:
                out.write(reply + "\n")
        if recorder:
            recorder.flush()
            rec_file.close()
            err.write("sma console: recorded %d telemetry rows to %s\n" % (recorder.rows, args.record))
        close = getattr(port, "close", None)
        if close:
            try:
                close()
            except Exception:
                pass
    return code
