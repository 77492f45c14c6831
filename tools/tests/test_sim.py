"""`sma sim`: the training signal is the paper's (slopes +-5.88e-3 V/s, decaying peaks), effects
and noise reach the log, and the log is a rig log with a metadata header."""
import numpy as np

from conftest import run_sma
from sma.plot import load_csv


def test_training_signal_shape(binaries, tmp_path):
    log = tmp_path / "train.csv"
    run_sma("sim", "--volt", "train", "--dt", "0.5", "--out", log)
    d, comments = load_csv(str(log))
    assert any("training signal" in c and "0.00588" in c for c in comments)
    t, v = d["t_s"], d["v_V"]
    slopes = np.diff(v) / np.diff(t)
    ramp = np.abs(slopes) > 1e-4
    ramp &= np.abs(slopes) < 0.1  # not the probe's steps
    # samples that straddle a peak or the floor see a partial slope; all others the paper's
    on = np.isclose(np.abs(slopes[ramp]), 5.88e-3, rtol=1e-6)
    assert on.mean() > 0.99
    # peaks: local maxima of the ramps decay after the first
    probe = t >= t[-1] + 0.5 - 9 * 20.0  # the last 180 s: 8 holds of 20 s, then 20 s off
    ramp_v = v[~probe]
    ramps = [ramp_v[i] for i in range(1, len(ramp_v) - 1)
             if ramp_v[i] > ramp_v[i - 1] and ramp_v[i] >= ramp_v[i + 1] and ramp_v[i] > 1.0]
    assert abs(ramps[0] - 2.0) < 1e-2 and len(ramps) == 12
    assert all(a > b for a, b in zip(ramps[:-1], ramps[1:]))
    # ends with the probe: holds up and down through the band, each 20 s, then 0
    held = [x for i, x in enumerate(v[probe]) if i == 0 or x != v[probe][i - 1]]
    assert held == [1.2, 1.35, 1.5, 1.3, 1.7, 1.0, 0.6, 1.4, 0.0]
    assert np.sum(v[probe] == 1.7) == 40  # 20 s at dt 0.5
    assert v.max() <= 2.0 + 1e-9 and v[-1] == 0.0


def test_effect_and_noise_reach_the_log(binaries, tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    run_sma("sim", "--volt", "const:0", "--duration", "2", "--out", a)
    run_sma("sim", "--volt", "const:0", "--duration", "2", "--effect", "sensor_calibration.offset_mm=0.5",
            "--noise", "0.01", "--seed", "3", "--out", b)
    da, db = load_csv(str(a))[0], load_csv(str(b))[0]
    assert np.all(da["d_mm"] == 0.0)
    assert abs(db["d_mm"].mean() - 0.5) < 0.005 and 0.005 < db["d_mm"].std() < 0.015
    text = b.read_text()
    assert '"sensor_calibration": {"offset_mm": 0.5}' in text.replace(":0.5", ": 0.5") or "offset_mm" in text


def test_closed_loop_tracks(binaries, tmp_path):
    log = tmp_path / "ms.csv"
    run_sma("sim", "--ref", "multistep", "--mode", "ffpid", "--out", log)
    d, comments = load_csv(str(log))
    assert any("closed loop" in c for c in comments)
    assert sorted(set(np.round(d["ref_mm"], 6))) == [0.2, 0.3, 0.4, 0.5, 0.6, 0.8]
    late = (d["t_s"] % 25 > 20) & (d["t_s"] < 75)  # end of the first three steps
    assert np.abs(d["ref_mm"][late] - d["d_mm"][late]).mean() < 0.02


def test_closed_loop_on_the_board_and_the_controller_alike(binaries, tmp_path):
    """The default closed loop runs the board's logic (sma::Board); --loop controller the
    controller alone: the same rig-log columns, the same reference, tracking alike (the board reads
    the position through its 10-bit ADC: 1.95 um per count)."""
    b, c = tmp_path / "b.csv", tmp_path / "c.csv"
    run_sma("sim", "--ref", "multistep", "--duration", "50", "--out", b)
    run_sma("sim", "--ref", "multistep", "--duration", "50", "--loop", "controller", "--out", c)
    (db, cb), (dc, cc) = load_csv(str(b)), load_csv(str(c))
    assert any("loop: board" in x for x in cb) and any("loop: controller" in x for x in cc)
    assert list(db) == list(dc)
    assert len(db) == len(dc) and np.allclose(db["ref_mm"], dc["ref_mm"], atol=1e-6)
    late = (db["t_s"] % 25 > 20)  # the end of each step: both hold the setpoint alike
    for d in (db, dc):
        assert np.abs(d["ref_mm"][late] - d["d_true_mm"][late]).max() < 0.02
    # where the wire is still, the board differs only by its ADC: one count, 5 V / 1024 x 0.4 mm/V
    count_mm = 5.0 / 1024 * 0.4
    assert np.abs(db["d_true_mm"][late] - dc["d_true_mm"][late]).max() < count_mm


def test_the_board_refuses_a_bad_command_with_its_err_line(binaries, tmp_path):
    r = run_sma("sim", "--ref", "sine", "--send", "tlim 500", "--out", tmp_path / "x.csv", check=False)
    assert r.returncode == 1
    assert "the board refused 'tlim 500': ERR tlim:" in r.stderr
    assert not (tmp_path / "x.csv").exists()
    # what the board fixes (rig_config.h) is refused by name, not silently changed
    r = run_sma("sim", "--ref", "sine", "--dt", "0.02", "--out", tmp_path / "y.csv", check=False)
    assert r.returncode == 1 and "--dt" in r.stderr and "--loop controller" in r.stderr
