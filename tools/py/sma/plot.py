"""Plots of rig logs and fits (matplotlib, PNG).

The CSVs read here are written by the C++ helpers (sma_sim --replay, sma_fit), which already
validated the user's log strictly; the model's temperature comes from them, never from Python.
"""
import os

from . import riglog


def _mpl():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def load_csv(path):
    """(columns, comments) of a helper's CSV, by the one reader (riglog)."""
    return riglog.load(path)


def _decimate(n, limit=20000):
    return max(1, n // limit)


def _save(plt, fig, path):
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _finish_time_panels(ax, t, v):
    """The voltage panel at the bottom of a time plot, and the grid on every panel."""
    ax[-1].plot(t, v, lw=1, color="tab:red")
    ax[-1].set_ylabel("voltage v_V (V)")
    ax[-1].set_xlabel("time (s)")
    for a in ax:
        a.grid(alpha=0.3)


def _vs_temperature(plt, T, curves, xlabel, ylabel, title, path):
    """One figure of curves (label, y, style) against the wire temperature; -> path."""
    fig, ax = plt.subplots(figsize=(7, 5.5))
    for label, y, style in curves:
        ax.plot(T, y, label=label, **style)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    return _save(plt, fig, path)


def plot_log(replay_csv, out_dir, title):
    """replay_csv: the output of `sma_sim --replay` (log columns + d_model_mm, T_model_C)."""
    plt = _mpl()
    d, _ = load_csv(replay_csv)
    os.makedirs(out_dir, exist_ok=True)
    k = _decimate(len(d["t_s"]))
    t = d["t_s"][::k]
    has_ref = "ref_mm" in d
    fig, ax = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    ax[0].plot(t, d["d_mm"][::k], label="measured d_mm", lw=1)
    if has_ref:
        ax[0].plot(t, d["ref_mm"][::k], label="reference ref_mm", lw=1)
    ax[0].plot(t, d["d_model_mm"][::k], label="model (replay of v_V)", lw=1, ls="--", alpha=0.8)
    ax[0].set_ylabel("position (mm)")
    ax[0].legend(loc="best", fontsize=8)
    ax[0].set_title(title)
    if has_ref:
        ax[1].plot(t, (d["ref_mm"] - d["d_mm"])[::k], lw=1, label="ref - measured")
    ax[1].plot(t, (d["d_model_mm"] - d["d_mm"])[::k], lw=1, alpha=0.8, label="model - measured")
    ax[1].axhline(0, color="k", lw=0.5)
    ax[1].set_ylabel("error (mm)")
    ax[1].legend(loc="best", fontsize=8)
    _finish_time_panels(ax, t, d["v_V"][::k])
    p1 = _save(plt, fig, os.path.join(out_dir, "log_time.png"))
    p2 = _vs_temperature(plt, d["T_model_C"][::k],
                         [("measured d_mm", d["d_mm"][::k], {"lw": 1}),
                          ("model", d["d_model_mm"][::k], {"lw": 1, "ls": "--"})],
                         "wire temperature from the model (degC)", "displacement (mm)",
                         title + ": displacement vs model temperature", os.path.join(out_dir, "log_hysteresis.png"))
    return [p1, p2]


def plot_fit(out_dir):
    """Plots of a `sma_fit` result directory (fit_curves.csv, params.json, validate_curves.csv)."""
    import json

    plt = _mpl()
    with open(os.path.join(out_dir, "params.json")) as f:
        params = json.load(f)
    calib = params.get("effects", {}).get("sensor_calibration", {})
    gain, offset = calib.get("gain", 1.0), calib.get("offset_mm", 0.0)
    g = params["g"]
    written = []
    for name, label in (("fit_curves.csv", "training"), ("validate_curves.csv", "validation")):
        path = os.path.join(out_dir, name)
        if not os.path.exists(path):
            continue
        d, _ = load_csv(path)
        t = d["t_s"]
        fig, ax = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
        ax[0].plot(t, d["d_mm"], lw=1, label="measured")
        ax[0].plot(t, d["d_fit_mm"], lw=1, ls="--", label="fitted model")
        ax[0].plot(t, d["d_start_mm"], lw=0.8, ls=":", label="start parameters")
        ax[0].set_ylabel("displacement (mm)")
        ax[0].legend(loc="best", fontsize=8)
        ax[0].set_title("%s log: measured vs model" % label)
        ax[1].plot(t, d["d_fit_mm"] - d["d_mm"], lw=1)
        ax[1].axhline(0, color="k", lw=0.5)
        ax[1].set_ylabel("fit - measured (mm)")
        _finish_time_panels(ax, t, d["v_V"])
        written.append(_save(plt, fig, os.path.join(out_dir, "%s_time.png" % label)))
        if label != "training":
            continue
        T = d["T_fit_C"]
        xlabel = "wire temperature, fitted model (degC)"
        # Fig. 5: austenite fraction vs temperature (model loops; "measured" = (d - offset)/(gain g)).
        written.append(_vs_temperature(
            plt, T, [("measured (d - offset) / g", (d["d_mm"] - offset) / (gain * g), {"lw": 0.8, "color": "0.6"}),
                     ("fitted model", d["eps_fit"], {"lw": 1.2, "color": "tab:red"})],
            xlabel, "austenite fraction", "Austenite fraction vs temperature (cf. paper Fig. 5)",
            os.path.join(out_dir, "fit_fraction.png")))
        # Fig. 6: displacement vs temperature, measured vs fitted.
        written.append(_vs_temperature(
            plt, T, [("measured", d["d_mm"], {"lw": 0.8}),
                     ("fitted model", d["d_fit_mm"], {"lw": 1.2, "color": "tab:red", "ls": "--"})],
            xlabel, "displacement (mm)", "Displacement vs temperature (cf. paper Fig. 6)",
            os.path.join(out_dir, "fit_displacement.png")))
    return written
