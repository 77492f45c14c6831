"""fil_lead.py's --bound (bench_optimal_bound's JSON): the rig-like sine's bound is read, and a
file that is missing, malformed or without a usable rig-like sine gives a message and no bound
(the test then reports NOT CHECKED instead of failing on a division or a missing key)."""
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "vrig"))
import fil_lead  # noqa: E402

SINE = {"test": "sine", "condition": "rig-like", "max_mm": 0.019462, "rms_mm": 0.003568}


def _write(tmp_path, obj, name="bound.json"):
    p = tmp_path / name
    p.write_text(obj if isinstance(obj, str) else json.dumps(obj))
    return str(p)


def test_the_rig_like_sine_is_read(tmp_path):
    other = dict(SINE, condition="ideal", max_mm=0.02)
    b = fil_lead.sine_bound(_write(tmp_path, {"bounds": [other, SINE]}))
    assert b["max_mm"] == SINE["max_mm"] and b["rms_mm"] == SINE["rms_mm"]


def test_no_path_no_bound():
    assert fil_lead.sine_bound(None) is None


def test_bad_files_give_a_message_and_no_bound(tmp_path, capsys):
    cases = {
        "missing": str(tmp_path / "missing.json"),
        "not json": _write(tmp_path, "{bounds", "a.json"),
        "no bounds key": _write(tmp_path, {"objective": 1}, "b.json"),
        "bounds not a list": _write(tmp_path, {"bounds": 3}, "c.json"),
        "no rig-like sine": _write(tmp_path, {"bounds": [dict(SINE, condition="ideal")]}, "d.json"),
        "rms zero": _write(tmp_path, {"bounds": [dict(SINE, rms_mm=0)]}, "e.json"),
        "max not a number": _write(tmp_path, {"bounds": [dict(SINE, max_mm="x")]}, "f.json"),
        "rms missing": _write(tmp_path, {"bounds": [{k: v for k, v in SINE.items() if k != "rms_mm"}]}, "g.json"),
    }
    for what, path in cases.items():
        assert fil_lead.sine_bound(path) is None, what
        out = capsys.readouterr().out
        assert out.startswith("optimal bound:"), (what, out)
