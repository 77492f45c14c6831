"""`sma plot`: any rig log to PNGs, with the model's temperature from `sma_sim --replay`."""
from conftest import run_sma


def test_closed_loop_log_to_pngs(binaries, tmp_path):
    log = tmp_path / "sine.csv"
    run_sma("sim", "--ref", "sine", "--mode", "ffpid", "--rig-like", "--duration", "60", "--out", log)
    text = log.read_text()
    assert "t_s,v_V,d_mm,ref_mm,duty" in text and text.startswith("# sma_sim")
    out = tmp_path / "plots"
    r = run_sma("plot", log, "--out", out)
    for name in ("log_time.png", "log_hysteresis.png"):
        f = out / name
        assert f.exists() and f.stat().st_size > 10000
        assert str(f) in r.stdout


def test_replay_gives_the_model_temperature(binaries, tmp_path):
    log = tmp_path / "c.csv"
    run_sma("sim", "--volt", "const:1.0", "--duration", "60", "--out", log)
    rep = tmp_path / "rep.csv"
    run_sma("sim", "--replay", log, "--out", rep)
    from sma.plot import load_csv

    d, _ = load_csv(str(rep))
    # eq 1 steady state at 1.0 V with Table II: 49.56 degC (model.md)
    assert abs(d["T_model_C"][-1] - 49.56) < 0.05
    assert abs(d["T_model_C"][-1] - load_csv(str(log))[0]["T_true_C"][-1]) < 1e-3
