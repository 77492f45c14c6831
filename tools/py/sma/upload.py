"""`sma upload PARAMS.json --port PORT`: model parameters into the board's EEPROM.

The JSON (interfaces.md: Table II keys, `m`, `loops`, `effects`) is read by the project's one
reader (sma_tools::read_model, through the helper `sma_params`): unknown keys or a non-physical
set are refused, naming the key, before anything is sent. Missing keys take the paper's values:
every key is sent, so the board ends with exactly the file's model.

Protocol (sma/console.hpp): `pbegin` (a new set in the inactive EEPROM slot), `pset <key>
<value>` for every key (each answer carries the float32 bits read back from the EEPROM, checked
before anything is committed), `pcommit` (the board validates the whole set and switches to it
atomically), then `pget <key>` for every key (the active set, checked within float precision)
and `pinfo`. Any ERR, timeout or mismatch before the commit sends `pabort`: the board keeps its
old set. Exit codes: 0 ok, 1 bad file / ERR / mismatch, 2 port cannot be opened or helper
missing, 3 link lost, 4 no reply.
"""
import math
import struct
import subprocess
import sys

from . import console

LINE_MAX = 47


def float_bits(x):
    return struct.unpack("<I", struct.pack("<f", x))[0]


def bits_float(u):
    return struct.unpack("<f", struct.pack("<I", u))[0]


def read_keys(path, helper):
    """-> [(key, value)] in the board's key order; raises ValueError with the reader's message."""
    r = subprocess.run([helper, path], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise ValueError(r.stderr.strip().replace("sma_params: ", "", 1) or "cannot read %s" % path)
    out = []
    for line in r.stdout.splitlines():
        k, v = line.split()
        out.append((k, float(v)))
    return out


def format_value(v, room):
    """A plain decimal (the console takes no exponent) of v, about 9 significant digits, at most
    `room` characters."""
    if v == 0:
        return "0"
    dec = max(0, 8 - int(math.floor(math.log10(abs(v)))))
    while True:
        s = "%.*f" % (dec, v)
        if "." in s:
            s = s.rstrip("0").rstrip(".")
        if len(s) <= room or dec == 0:
            return s
        dec -= 1


def pset_line(key, value):
    """`pset <key> <value>` within the 47-char line; an effect key too long for its value's digits
    is sent as its parameter alone (sensor_delay.delay_s -> delay_s), which the board also
    accepts. The decimal sent must carry the float the board stores (it rounds to the same
    float32): a decimal cut short to fit a long name would add its own error to the board's
    parsing, and the read-back could then miss the value (0.00598381 for 0.00598381241)."""
    names = [key] + ([key.split(".", 1)[1]] if "." in key and not key.startswith("loop") else [])
    line = None
    for name in names:
        room = LINE_MAX - len("pset ") - len(name) - 1
        line = "pset %s %s" % (name, "%d" % value if key == "loops" else format_value(value, room))
        if len(line) <= LINE_MAX and (key == "loops" or carries_float(line.split()[-1], value)):
            return line
    return line  # the most room: the closest decimal there is


def carries_float(decimal, value):
    """The decimal rounds to the float32 of value."""
    got = parse_decimal(decimal)
    return got == got and float_bits(got) == float_bits(value)


def parse_decimal(s):
    try:
        return float(s)
    except ValueError:
        return float("nan")


def float_close(got, want, key):
    """Equal within float precision (the board stores float32 and parses decimals in float)."""
    if key == "loops":
        return int(got) == int(want)
    w = bits_float(float_bits(want))
    return abs(got - w) <= 4e-7 * max(abs(w), 1e-30) or got == w


class UploadError(Exception):
    pass


def upload(client, keys, out=sys.stdout, timeout=2.0, write_timeout=10.0):
    """Runs the upload on a ConsoleClient. Raises UploadError with a clear message on any ERR or
    mismatch; pabort is sent if the commit was not reached."""
    committed = False

    def send(cmd, t=timeout):
        text = client.send(cmd, timeout=t, check=False)
        if not text.startswith("OK"):
            raise UploadError("the board refused '%s': %s" % (cmd, text))
        return text

    try:
        send("pbegin", write_timeout)  # copies the active set into the other slot: ~0.8 s on a board
        for key, value in keys:
            line = pset_line(key, value)
            if len(line) > LINE_MAX:
                raise UploadError("%s: value %r does not fit a console line" % (key, value))
            text = send(line, write_timeout)
            w = text.split()
            if len(w) != 4 or w[2] != key:
                raise UploadError("unexpected answer to '%s': %s" % (line, text))
            got = int(w[3], 16) if key == "loops" else bits_float(int(w[3], 16))
            if not float_close(got, value, key):
                raise UploadError("%s: the board stored %r for %r ('%s')" % (key, got, value, line))
        text = send("pcommit", write_timeout)
        committed = True
        out.write(text + "\n")
        bad = []
        for key, value in keys:
            w = send("pget " + key).split()
            got = int(w[-1], 16) if key == "loops" else bits_float(int(w[-1], 16))
            if not float_close(got, value, key):
                bad.append("%s: board %r, file %r" % (key, got, value))
        if bad:
            raise UploadError("read back after pcommit differs (the new set IS active):\n  " + "\n  ".join(bad))
        out.write(send("pinfo") + "\n")
    except (UploadError, TimeoutError, console.LinkLost) as e:
        if not committed:
            try:
                client.send("pabort", timeout=timeout, check=False)
            except Exception:
                pass
            if isinstance(e, UploadError):
                raise UploadError(str(e) + "\n(pabort sent: the board keeps its old set)")
        raise


def run(args, port=None, out=sys.stdout, err=sys.stderr, helper=None):
    """The `sma upload` command; returns the exit code."""
    helper = helper or console.params_helper("sma upload", err)
    if helper is None:
        return 2
    try:
        keys = read_keys(args.params, helper)
    except (ValueError, OSError) as e:
        err.write("sma upload: %s\n" % e)
        return 1

    def exchange(c):
        if args.stop:
            c.send("stop", timeout=args.timeout, check=False)
        upload(c, keys, out=out, timeout=args.timeout)

    rc = console.board_exchange("sma upload", args, port, err, exchange, UploadError)
    if rc != 0:
        return rc
    out.write("sma upload: %d keys of %s verified on the board\n" % (len(keys), args.params))
    return 0
