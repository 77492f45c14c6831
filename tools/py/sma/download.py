"""`sma download --port PORT -o board.json`: the board's active model as a params JSON.

The reverse of `sma upload` (upload.py), like grbl's `$$`: `pinfo` (store version, slot,
sequence, CRC), then `pget <key>` for every key of the board (the keys `sma_params` prints, in
the board's order). Each answer carries the stored float32 bits, taken exactly. The `key value`
lines go through the project's one writer (`sma_params --from-keys`: sma_tools::model_to_json),
which also refuses a set that is not physical, naming the key. `sma upload board.json` restores
it. Exit codes: 0 ok, 1 ERR/bad answer/bad set, 2 port cannot be opened or helper missing,
3 link lost, 4 no reply.
"""
import os
import subprocess
import sys
import tempfile

from . import console, upload


class DownloadError(Exception):
    pass


def board_keys(helper):
    """The board's keys, in its order (sma_params on an empty params JSON)."""
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "empty.json")
        with open(p, "w") as f:
            f.write("{}")
        return [k for k, _ in upload.read_keys(p, helper)]


def download(client, keys, timeout=2.0):
    """-> (pinfo line, [(key, value)]) read from the board on a ConsoleClient."""
    info = client.send("pinfo", timeout=timeout, check=False)
    if not info.startswith("OK pinfo"):
        raise DownloadError("the board refused 'pinfo': %s" % info)
    out = []
    for key in keys:
        text = client.send("pget " + key, timeout=timeout, check=False)
        w = text.split()
        if len(w) != 5 or w[:3] != ["OK", "pget", key] or not w[4].startswith("0x"):
            raise DownloadError("unexpected answer to 'pget %s': %s" % (key, text))
        bits = int(w[4], 16)
        out.append((key, float(bits) if key == "loops" else upload.bits_float(bits)))
    return info, out


def to_json(pairs, helper):
    """`key value` pairs -> params JSON text (sma_params --from-keys); ValueError on a bad set."""
    text = "".join("%s %s\n" % (k, "%d" % v if k == "loops" else repr(v)) for k, v in pairs)
    r = subprocess.run([helper, "--from-keys"], input=text, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       text=True)
    if r.returncode != 0:
        raise ValueError(r.stderr.strip().replace("sma_params: ", "", 1))
    return r.stdout


def run(args, port=None, out=sys.stdout, err=sys.stderr, helper=None):
    """The `sma download` command; returns the exit code."""
    helper = helper or console.params_helper("sma download", err)
    if helper is None:
        return 2
    try:
        keys = board_keys(helper)
    except (ValueError, OSError) as e:
        err.write("sma download: %s\n" % e)
        return 2
    got = {}

    def exchange(c):
        got["info"], got["pairs"] = download(c, keys, timeout=args.timeout)
        got["text"] = to_json(got["pairs"], helper)

    rc = console.board_exchange("sma download", args, port, err, exchange, (DownloadError, ValueError))
    if rc != 0:
        return rc
    info, pairs, text = got["info"], got["pairs"], got["text"]
    try:
        with open(args.output, "w") as f:
            f.write(text)
    except OSError as e:
        err.write("sma download: cannot write %s: %s\n" % (args.output, e))
        return 1
    out.write("sma download: %d keys into %s (%s)\n" % (len(pairs), args.output, info[3:]))
    return 0
