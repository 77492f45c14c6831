"""`sma dashboard --port P`: the rig live in the browser.

A local web page (Python's http.server and a small JS page in sma/web/, nothing from the
network) with live plots of position and reference, the voltage and the firmware's estimated
wire temperature, the safety latch, a command box with the console's replies, recording to a
rig log, and a button that stops the heater.

The board's telemetry rows (`tele on`: t_s,v_V,d_mm,ref_mm,duty) give the traces; `status`,
polled twice a second, gives the firmware's wire temperature T and the latch (fault=...). The
page polls /api/state; commands go through /api/command and wait for the board's OK/ERR.

Safety and sharing:
  - it listens on 127.0.0.1 only unless --bind says otherwise (a page that can heat a wire must
    not be reachable from the network by accident), and refuses requests whose Host header is
    not the address it listens on (DNS rebinding) and POSTs that are not JSON (cross-site forms);
  - one page at a time controls the rig (commands, recording, release); others watch. Stop is
    accepted from every page: heater off is always allowed;
  - the port is opened exclusively (console.open_port): `sma upload` on the same port fails with
    a message naming the dashboard; "Release port" (or POST /api/release) closes it, "Connect"
    takes it back.
"""
import json
import os
import re
import secrets
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

from . import console
from .upload import LINE_MAX

WEB = os.path.join(os.path.dirname(os.path.abspath(__file__)), "web")
KEEP_ROWS = 6000            # 60 s of telemetry at 100 Hz
STATUS_PERIOD = 0.5         # s between status polls
CONTROLLER_TIMEOUT = 5.0    # s without a poll before another page may take control
STATUS_FIELD = re.compile(r"(\w+)=(\S+)")


class Rig:
    """The serial side: one thread owns the port; everything else goes through its lock."""

    def __init__(self, url, baud, log=None):
        self.url = url
        self.baud = baud
        self.log = log or (lambda text: sys.stderr.write("sma dashboard: " + text + "\n"))
        self.lock = threading.Lock()
        self.port = None
        self.client = None
        self.error = None
        self.rows = []            # (seq, row)
        self.seq = 0
        self.lines = []           # (n, kind, text) console lines for the page
        self.nlines = 0
        self.status = {}
        self.status_seq = 0
        self.plotter_named = False
        self.pending = []         # commands sent, waiting for their reply: [cmd, event, reply, quiet]
        self.recorder = None
        self.rec_file = None
        self.rec_path = None
        self._thread = None
        self._stop = threading.Event()

    # ---- connection -------------------------------------------------------------------------
    def connect(self):
        with self.lock:
            if self.port is not None:
                return True
            errors = []

            class Sink:
                def write(self, text):
                    errors.append(text.strip())

            port = console.open_port(self.url, self.baud, "sma dashboard", Sink(), exclusive=True)
            if port is None:
                self.error = errors[0] if errors else "cannot open %s" % self.url
                self.lines_append("error", self.error)
                self.log(self.error.replace("sma dashboard: ", "", 1))
                return False
            self.port = port
            self.client = console.ConsoleClient(port)
            self.error = None
            self._stop.clear()
            self._thread = threading.Thread(target=self._loop, daemon=True)
            self._thread.start()
        self._line("info", "connected to %s" % self.url)
        self.log("connected to %s" % self.url)
        self.command("tele on", quiet=True, wait=False)
        return True

    def release(self):
        """Closes the port so that another tool (sma upload) can use it."""
        self.stop_recording()
        self._stop.set()
        t = self._thread
        if t is not None:
            t.join(timeout=2.0)
        with self.lock:
            if self.port is not None:
                try:
                    self.port.close()
                except Exception:
                    pass
            self.port = None
            self.client = None
            self._fail_pending("port released")
        self._line("info", "port %s released: other tools may use it" % self.url)
        self.log("port %s released" % self.url)

    def _fail_pending(self, why):
        for p in self.pending:
            p[2] = "ERR " + why
            p[1].set()
        self.pending = []

    # ---- console lines ----------------------------------------------------------------------
    def _line(self, kind, text):
        """A line for the page; never called with the lock held (lines_append is, under it)."""
        with self.lock:
            self.lines_append(kind, text)

    def _loop(self):
        last_status = 0.0
        while not self._stop.is_set():
            try:
                data = self.client._read()
            except console.LinkLost as e:
                with self.lock:
                    self.error = "link lost: %s" % e
                    self.port = None
                    self._fail_pending(self.error)
                self._line("error", self.error + " (heater state unknown)")
                self.log(self.error)
                self.stop_recording()
                return
            if data:
                with self.lock:
                    for kind, payload in self.client.feed(data):
                        self._handle(kind, payload)
            now = time.monotonic()
            if now - last_status >= STATUS_PERIOD:
                last_status = now
                self.command("status", quiet=True, wait=False)

    def _handle(self, kind, payload):
        """Called with the lock held."""
        if kind == "row":
            self.seq += 1
            self.rows.append((self.seq, payload))
            del self.rows[:-KEEP_ROWS]
            if self.recorder:
                self.recorder.row(payload)
        elif kind == "reply":
            ok, text = payload
            entry = self.pending.pop(0) if self.pending else None
            if text.startswith("OK status"):
                self.status = dict(STATUS_FIELD.findall(text))
                self.status["line"] = text
                # status's t= is the reference's time: the plot places T at the telemetry's time
                self.status_seq += 1
                self.status["seq"] = self.status_seq
                self.status["t_row"] = self.rows[-1][1][0] if self.rows else None
            if entry is None or not entry[3] or not ok:
                self.lines_append("reply" if ok else "err", text)
            if not ok:
                self.log("board: %s (to '%s')" % (text, entry[0] if entry else "?"))
            if entry is not None:
                entry[2] = text
                entry[1].set()
        elif kind == "plotter":
            if not self.plotter_named:  # named once, on the page and in the terminal
                self.plotter_named = True
                self.lines_append("info", console.PLOTTER_NOTE)
                self.log(console.PLOTTER_NOTE)
        elif kind in ("comment", "other"):
            self.lines_append("comment", ("# " if kind == "comment" else "") + payload)
            if self.recorder and kind == "comment":
                self.recorder.comment(payload)

    def lines_append(self, kind, text):
        self.nlines += 1
        self.lines.append((self.nlines, kind, text))
        del self.lines[:-200]

    def command(self, line, quiet=False, wait=True, timeout=2.0):
        """Sends a line; -> the reply text (OK/ERR ...), or an ERR text when there is none."""
        line = line.strip()
        if not line:
            return "ERR empty command"
        if len(line) > LINE_MAX:
            return "ERR line longer than %d characters: the board would refuse it" % LINE_MAX
        ev = threading.Event()
        entry = [line, ev, None, quiet]
        with self.lock:
            if self.client is None:
                return "ERR not connected%s" % (": " + self.error if self.error else "")
            if not quiet:
                self.lines_append("cmd", "> " + line)
            self.pending.append(entry)
            try:
                self.client.write_line(line)
            except console.LinkLost as e:
                self.pending.remove(entry)
                return "ERR link lost: %s" % e
        if not wait:
            return None
        if not ev.wait(timeout):
            with self.lock:
                if entry in self.pending:
                    self.pending.remove(entry)
            msg = "ERR no reply to '%s' within %.0f s" % (line, timeout)
            self._line("err", msg)
            self.log(msg)
            return msg
        return entry[2]

    # ---- recording ----------------------------------------------------------------------------
    def start_recording(self, path):
        with self.lock:
            if self.recorder:
                return "already recording to %s" % self.rec_path
            try:
                f = open(path, "w")
            except OSError as e:
                return "cannot record to %s: %s" % (path, e)
            self.rec_file, self.rec_path = f, path
            self.recorder = console.Recorder(f, self.url)
        self._line("info", "recording to %s" % path)
        self.log("recording to %s" % path)
        return None

    def stop_recording(self):
        with self.lock:
            if not self.recorder:
                return None
            rec, f, path = self.recorder, self.rec_file, self.rec_path
            self.recorder = self.rec_file = None
            rec.flush()
            f.close()
        msg = "recorded %d telemetry rows to %s" % (rec.rows, path)
        self._line("info", msg)
        self.log(msg)
        return msg

    # ---- what the page sees -------------------------------------------------------------------
    def state(self, since_row, since_line):
        with self.lock:
            rows = [r for s, r in self.rows if s > since_row]
            if len(rows) > KEEP_ROWS:
                rows = rows[-KEEP_ROWS:]
            return {
                "connected": self.port is not None, "port": self.url, "error": self.error,
                "seq": self.seq, "rows": rows,
                "lines": [[n, k, t] for n, k, t in self.lines if n > since_line], "nline": self.nlines,
                "status": self.status,
                "recording": {"file": self.rec_path, "rows": self.recorder.rows} if self.recorder else None,
            }

    def close(self):
        if self.port is not None:
            self.command("stop", quiet=True, timeout=1.0)
        self.release()


class Control:
    """One controlling page at a time: a token, kept alive by the page's polls."""

    def __init__(self, clock=time.monotonic):
        self.token = None
        self.seen = 0.0
        self.clock = clock
        self.lock = threading.Lock()

    def claim(self):
        with self.lock:
            now = self.clock()
            if self.token is not None and now - self.seen < CONTROLLER_TIMEOUT:
                return None
            self.token = secrets.token_hex(16)
            self.seen = now
            return self.token

    def check(self, token):
        with self.lock:
            if token and token == self.token:
                self.seen = self.clock()
                return True
            return False


def make_handler(rig, control, allowed_hosts, record_dir):
    class Handler(BaseHTTPRequestHandler):
        server_version = "sma-dashboard"

        def log_message(self, fmt, *args):  # the terminal shows the rig's messages, not every GET
            pass

        def _host_ok(self):
            host = (self.headers.get("Host") or "").rsplit(":", 1)[0].strip("[]")
            if allowed_hosts is None or host in allowed_hosts:
                return True
            self._send(403, {"error": "host %s not allowed" % host})
            return False

        def _send(self, code, obj, ctype="application/json"):
            body = obj if isinstance(obj, bytes) else json.dumps(obj).encode()
            self.send_response(code)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(body)

        def do_GET(self):
            if not self._host_ok():
                return
            path, _, query = self.path.partition("?")
            if path == "/api/state":
                q = dict(p.split("=", 1) for p in query.split("&") if "=" in p)
                try:
                    since_row, since_line = int(q.get("since", "0")), int(q.get("line", "0"))
                except ValueError:
                    return self._send(400, {"error": "since/line must be integers"})
                st = rig.state(since_row, since_line)
                st["controller"] = control.check(self.headers.get("X-Sma-Token"))
                return self._send(200, st)
            files = {"/": ("index.html", "text/html; charset=utf-8"), "/app.js": ("app.js", "text/javascript"),
                     "/style.css": ("style.css", "text/css")}
            if path not in files:
                return self._send(404, {"error": "not found"})
            name, ctype = files[path]
            with open(os.path.join(WEB, name), "rb") as f:
                self._send(200, f.read(), ctype)

        def do_POST(self):
            if not self._host_ok():
                return
            if not (self.headers.get("Content-Type") or "").startswith("application/json"):
                return self._send(415, {"error": "JSON only"})
            try:
                n = int(self.headers.get("Content-Length") or 0)
                body = json.loads(self.rfile.read(n) or b"{}")
            except ValueError:
                return self._send(400, {"error": "bad JSON"})
            path = self.path
            if path == "/api/claim":
                tok = control.claim()
                if tok is None:
                    return self._send(409, {"error": "another page controls the rig: this one only watches "
                                                     "(close the other page, or wait 5 s after it closes)"})
                return self._send(200, {"token": tok})
            if path == "/api/stop":  # heater off: from every page
                reply = rig.command("stop")
                if reply and reply.startswith("OK"):
                    rig.log("heater off (stop from the page)")
                return self._send(200, {"reply": reply})
            if not control.check(self.headers.get("X-Sma-Token")):
                return self._send(403, {"error": "this page does not control the rig (another page does)"})
            if path == "/api/command":
                line = str(body.get("line", ""))
                reply = rig.command(line)
                return self._send(200, {"reply": reply, "ok": bool(reply) and reply.startswith("OK")})
            if path == "/api/record":
                if body.get("action") == "start":
                    name = os.path.basename(str(body.get("file") or "")) or time.strftime("rig-%Y%m%d-%H%M%S.csv")
                    err = rig.start_recording(os.path.join(record_dir, name))
                    return self._send(200 if err is None else 400, {"error": err, "file": rig.rec_path})
                return self._send(200, {"message": rig.stop_recording()})
            if path == "/api/release":
                rig.release()
                return self._send(200, {"connected": False})
            if path == "/api/connect":
                ok = rig.connect()
                return self._send(200 if ok else 400, {"connected": ok, "error": rig.error})
            return self._send(404, {"error": "not found"})

    return Handler


def _start_vrig(args, err):
    """The firmware in the virtual rig on a pseudo-terminal (tools/vrig/pty_board.py)."""
    from . import build

    root = build.root()
    if root is None:
        err.write("sma dashboard: --vrig needs the repository (run inside a clone or set SMA_ROOT)\n")
        return None
    try:
        vrig = build.tool("vrig")
    except build.BuildError as e:
        err.write("sma dashboard: %s\n" % e)
        return None
    elf = args.elf or os.path.join(build.build_dir(), "firmware", "sma_firmware.elf")
    if not os.path.isfile(elf):
        err.write("sma dashboard: no firmware ELF %s: cmake --build build --target sma_firmware\n" % elf)
        return None
    sys.path.insert(0, os.path.join(root, "tools", "vrig"))
    from pty_board import PtyBoard

    board = PtyBoard(vrig, elf, duration=args.vrig_duration, extra=["--noise-mm", "0.002"])
    err.write("sma dashboard: the firmware %s in the virtual rig on %s\n" % (elf, board.port))
    return board


def run(args, err=sys.stderr):
    """The `sma dashboard` command; returns the exit code (runs until Ctrl-C)."""
    board = None
    if args.vrig:
        board = _start_vrig(args, err)
        if board is None:
            return 2
        args.port = board.port
    elif not args.port:
        err.write("sma dashboard: give --port PORT (a board, a pseudo-terminal) or --vrig\n")
        return 2
    rig = Rig(args.port, args.baud, log=lambda text: (err.write("sma dashboard: " + text + "\n"), err.flush()))
    rig.connect()  # a port that cannot be opened is shown on the page, which can retry
    local = args.bind in ("127.0.0.1", "localhost", "::1")
    allowed = {"127.0.0.1", "localhost", "::1"} if local else None
    if not local:
        err.write("sma dashboard: WARNING listening on %s: anyone who reaches this address can heat the wire\n"
                  % args.bind)
    try:
        server = ThreadingHTTPServer((args.bind, args.http_port),
                                     make_handler(rig, Control(), allowed, os.path.abspath(args.record_dir)))
    except OSError as e:
        err.write("sma dashboard: cannot listen on %s:%d: %s\n" % (args.bind, args.http_port, e))
        rig.close()
        if board:
            board.close()
        return 2
    server.daemon_threads = True
    host, port = server.server_address[:2]
    err.write("sma dashboard: http://%s:%d/  (Ctrl-C ends: heater off, port released)\n"
              % ("127.0.0.1" if local else host, port))
    err.flush()
    if args.url_file:
        # Whole or not at all: a program that waits for the file never reads it half written.
        tmp = args.url_file + ".tmp"
        with open(tmp, "w") as f:
            f.write("http://127.0.0.1:%d/\n%s\n" % (port, args.port))
        os.replace(tmp, args.url_file)
    try:
        server.serve_forever(poll_interval=0.2)
    except KeyboardInterrupt:
        err.write("\nsma dashboard: interrupted: sending stop\n")
    finally:
        server.server_close()
        rig.close()
        if board:
            board.close()
    return 0


def add_parser(sub):
    d = sub.add_parser("dashboard", help="the rig live in the browser: plots, commands, recording, stop",
                       description=__doc__.split("\n\n")[0] + " " + __doc__.split("\n\n")[1].replace("\n", " "))
    d.add_argument("--port", help="serial port: a board (/dev/ttyACM0), a pseudo-terminal, a pyserial URL")
    d.add_argument("--vrig", action="store_true",
                   help="start the firmware in the virtual rig on a pseudo-terminal and show it")
    d.add_argument("--elf", help="firmware ELF for --vrig (default BUILD/firmware/sma_firmware.elf)")
    d.add_argument("--vrig-duration", type=float, default=3600.0, help="virtual rig time for --vrig (s)")
    d.add_argument("--baud", type=int, default=115200)
    d.add_argument("--http-port", type=int, default=8765, help="web page port (default 8765; 0 = any free)")
    d.add_argument("--bind", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1: this machine only; 0.0.0.0 exposes the "
                        "heater to the network)")
    d.add_argument("--record-dir", default=".", help="where recordings go (default: the current directory)")
    d.add_argument("--url-file", help=argparse_suppress())
    return d


def argparse_suppress():
    import argparse

    return argparse.SUPPRESS
