"""`sma upload` against a fake board that speaks the model commands of sma/console.hpp (pbegin,
pset, pget, pcommit, pabort, pinfo): the happy path, and every way it can go wrong leaves the
board's active set untouched (pabort before any commit)."""
import os
import struct
import types

import pytest

from sma import build, console, upload


def bits(x):
    return struct.unpack("<I", struct.pack("<f", x))[0]


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


@pytest.fixture(scope="module")
def helper():
    """$SMA_PARAMS, or the sma_params of the build that made $SMA_SIM (CTest), or built now."""
    if not os.environ.get("SMA_PARAMS") and os.environ.get("SMA_SIM"):
        p = os.path.join(os.path.dirname(os.path.dirname(os.environ["SMA_SIM"])), "vrig", "sma_params")
        if os.path.isfile(p):
            return p
    return build.tool("sma_params")


@pytest.fixture(scope="module")
def keys_default(helper, tmp_path_factory):
    p = tmp_path_factory.mktemp("p") / "empty.json"
    p.write_text("{}")
    return dict(upload.read_keys(str(p), helper))


class FakeBoard:
    """Active and staged sets as dicts of float32 values; answers like the firmware.
    corrupt: key whose stored bits differ from what was sent; refuse: key answered with ERR;
    commit_err: pcommit answers ERR; heat: the heater is on."""

    def __init__(self, defaults, corrupt=None, refuse=None, commit_err=None, heat=False, drop_after=None):
        self.active = dict(defaults)
        self.staged = None
        self.out = b""
        self.written = []
        self.corrupt, self.refuse, self.commit_err, self.heat = corrupt, refuse, commit_err, heat
        self.drop_after = drop_after
        self.seq = 0

    def write(self, data):
        for line in data.decode().splitlines():
            self.written.append(line)
            if self.drop_after is not None and len(self.written) > self.drop_after:
                continue  # no answer: the link went quiet
            self.out += (self.reply(line) + "\r\n").encode()

    def read(self, n):
        d, self.out = self.out[:n], self.out[n:]
        return d

    def key(self, name):
        short = {k.split(".", 1)[1]: k for k in self.active if "." in k and not k.startswith("loop")}
        return name if name in self.active else short.get(name)

    def reply(self, line):
        w = line.split()
        if w[0] in ("pbegin", "pset", "pcommit") and self.heat:
            return "ERR %s: heater on, send stop" % w[0]
        if w[0] == "stop":
            self.heat = False
            return "OK stop"
        if w == ["pbegin"]:
            self.staged = dict(self.active)
            return "OK pbegin slot 1"
        if w[0] == "pset":
            k = self.key(w[1])
            if k is None:
                return "ERR pset: unknown key '%s'" % w[1]
            if self.staged is None:
                return "ERR pset: no staged set, send pbegin"
            if k == self.refuse:
                return "ERR %s: value out of range 0..1" % k
            v = float(w[2])
            if k == self.corrupt:
                v += 1.0
            self.staged[k] = v if k == "loops" else f32(v)
            return "OK pset %s %s" % (k, "0x%02x" % int(v) if k == "loops" else "0x%08x" % bits(v))
        if w == ["pcommit"]:
            if self.staged is None:
                return "ERR pcommit: no staged set, send pbegin"
            if self.commit_err:
                return self.commit_err
            self.active, self.staged = self.staged, None
            self.seq += 1
            return "OK pcommit v1 slot 1 seq %d crc 0x1234" % self.seq
        if w == ["pabort"]:
            self.staged = None
            return "OK pabort"
        if w[0] == "pget":
            k = self.key(w[1])
            v = self.active[k]
            return "OK pget %s %g %s" % (k, v, "0x%02x" % int(v) if k == "loops" else "0x%08x" % bits(v))
        if w == ["pinfo"]:
            return "OK pinfo v1 slot 1 seq %d crc 0x1234" % self.seq
        return "ERR unknown command '%s' (try help)" % w[0]


def args_for(path, stop=False):
    return types.SimpleNamespace(params=str(path), port="fake", baud=115200, timeout=0.5, stop=stop)


WIRE = '{"T_AS": 55.2, "T_AF": 84.1, "h": 214.5, "g": 1.1496, "d0": 0.000523456, "m": [1, -4.8, 10.2, -8.6, 0, 2.2],' \
       ' "loops": [{"T_i": 63.1, "T_ii": 61.2, "j": 0.16}, {"T_i": 69.0, "T_ii": 60.0, "j": 0.25}],' \
       ' "effects": {"convection_nonlinear": {"beta_per_K": 0.001234567}, "sensor_delay": {"delay_s": 0.05}}}'


def run_upload(board, tmp_path, helper, text=WIRE, stop=False):
    p = tmp_path / "wire.json"
    p.write_text(text)
    out, err = [], []
    o = types.SimpleNamespace(write=out.append)
    e = types.SimpleNamespace(write=err.append)
    rc = upload.run(args_for(p, stop), port=board, out=o, err=e, helper=helper)
    return rc, "".join(out), "".join(err)


def test_upload_sends_every_key_commits_and_verifies(tmp_path, helper, keys_default):
    b = FakeBoard(keys_default)
    rc, out, err = run_upload(b, tmp_path, helper)
    assert rc == 0, err
    assert "57 keys" in out and "OK pcommit" in out
    assert b.written[0] == "pbegin"
    psets = [l for l in b.written if l.startswith("pset")]
    assert len(psets) == 57
    assert all(len(l) <= 47 for l in b.written)
    assert "pset beta_per_K 0.001234567" in psets  # the long key + value would not fit 47 chars
    assert "pset loops 2" in psets
    assert b.written.index("pcommit") > b.written.index(psets[-1])
    assert abs(b.active["T_AS"] - 55.2) < 1e-5 and b.active["loops"] == 2
    assert abs(b.active["d0"] - 0.000523456) < 1e-6 * 0.000523456  # float32
    assert abs(b.active["loop1.j"] - 0.25) < 1e-7
    assert b.active["T_MS"] == keys_default["T_MS"]  # missing keys: the paper's values
    assert len([l for l in b.written if l.startswith("pget")]) == 57


@pytest.mark.parametrize("kw, words", [
    (dict(refuse="g"), ["refused", "pset g", "out of range", "keeps its old set"]),
    (dict(corrupt="T_AF"), ["T_AF", "stored", "keeps its old set"]),
    (dict(commit_err="ERR T_AF: must be > T_AS"), ["pcommit", "T_AF: must be > T_AS", "keeps its old set"]),
    (dict(heat=True), ["pbegin", "heater on", "keeps its old set"]),
])
def test_any_err_or_mismatch_aborts_and_keeps_the_old_set(tmp_path, helper, keys_default, kw, words):
    b = FakeBoard(keys_default, **kw)
    before = dict(b.active)
    rc, out, err = run_upload(b, tmp_path, helper)
    assert rc == 1
    for w in words:
        assert w in err, err
    assert b.active == before
    assert "pcommit" not in b.written or kw.get("commit_err")
    assert b.written[-1] == "pabort"


def test_stop_option_turns_the_heater_off_first(tmp_path, helper, keys_default):
    b = FakeBoard(keys_default, heat=True)
    rc, out, err = run_upload(b, tmp_path, helper, stop=True)
    assert rc == 0, err
    assert b.written[0] == "stop"


def test_bad_file_is_refused_before_anything_is_sent(tmp_path, helper, keys_default):
    for text, word in [('{"T_AZ": 1}', "unknown key 'T_AZ'"), ('{"T_AF": 40}', "T_AF: must be > T_AS"),
                       ('{"effects": {"sensor_delai": {}}}', "unknown effect 'sensor_delai'"),
                       ('{"T_AS": ', "wire.json")]:
        b = FakeBoard(keys_default)
        rc, out, err = run_upload(b, tmp_path, helper, text=text)
        assert rc == 1 and word in err, (text, err)
        assert b.written == []


def test_silent_board_times_out_with_exit_4(tmp_path, helper, keys_default):
    b = FakeBoard(keys_default, drop_after=3)
    rc, out, err = run_upload(b, tmp_path, helper)
    assert rc == 4 and "no reply" in err
    assert b.active == keys_default


def test_pset_lines_fit_and_parse_back_within_float_precision():
    for key, v in [("rho", 6500.0), ("d0", 0.000523456789), ("m2", -12345.6789), ("q", -32.6936),
                   ("convection_nonlinear.beta_per_K", 0.0999999), ("resistance_phase.k_R", -0.85),
                   ("sensor_calibration.offset_mm", -99.123456), ("loop7.T_ii", 61.2),
                   ("convection_nonlinear.beta_per_K", 0.00598381241)]:  # (the e2e flow's fit once)
        line = upload.pset_line(key, v)
        assert len(line) <= 47, line
        assert upload.float_close(float(line.split()[-1]), v, key), line
        # The decimal sent is the float itself: the board's own parsing is the only error left.
        assert key == "loops" or upload.carries_float(line.split()[-1], v), line
