"""Plots of rig logs and fits (matplotlib, PNG).

The CSVs read here are written by the C++ helpers (sma_sim --replay, sma_fit), which already
validated the user's log strictly; the model's temperature comes from them, never from Python.
"""
import os

import numpy as np

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
    ax[2].plot(t, d["v_V"][::k], lw=1, color="tab:red")
    ax[2].set_ylabel("voltage v_V (V)")
    ax[2].set_xlabel("time (s)")
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    p1 = os.path.join(out_dir, "log_time.png")
    fig.savefig(p1, dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 5.5))
    ax.plot(d["T_model_C"][::k], d["d_mm"][::k], lw=1, label="measured d_mm")
    ax.plot(d["T_model_C"][::k], d["d_model_mm"][::k], lw=1, ls="--", label="model")
    ax.set_xlabel("wire temperature from the model (degC)")
    ax.set_ylabel("displacement (mm)")
    ax.set_title(title + ": displacement vs model temperature")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    p2 = os.path.join(out_dir, "log_hysteresis.png")
    fig.savefig(p2, dpi=110)
    plt.close(fig)
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
        ax[2].plot(t, d["v_V"], lw=1, color="tab:red")
        ax[2].set_ylabel("v_V (V)")
        ax[2].set_xlabel("time (s)")
        for a in ax:
            a.grid(alpha=0.3)
        fig.tight_layout()
        p = os.path.join(out_dir, "%s_time.png" % label)
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)
        if label != "training":
            continue
        # Fig. 5: austenite fraction vs temperature (model loops; "measured" = (d - offset)/(gain g)).
        T = d["T_fit_C"]
        fig, ax = plt.subplots(figsize=(7, 5.5))
        ax.plot(T, (d["d_mm"] - offset) / (gain * g), lw=0.8, color="0.6", label="measured (d - offset) / g")
        ax.plot(T, d["eps_fit"], lw=1.2, color="tab:red", label="fitted model")
        ax.set_xlabel("wire temperature, fitted model (degC)")
        ax.set_ylabel("austenite fraction")
        ax.set_title("Austenite fraction vs temperature (cf. paper Fig. 5)")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
        fig.tight_layout()
        p = os.path.join(out_dir, "fit_fraction.png")
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)
        # Fig. 6: displacement vs temperature, measured vs fitted.
        fig, ax = plt.subplots(figsize=(7, 5.5))
        ax.plot(T, d["d_mm"], lw=0.8, label="measured")
        ax.plot(T, d["d_fit_mm"], lw=1.2, color="tab:red", ls="--", label="fitted model")
        ax.set_xlabel("wire temperature, fitted model (degC)")
        ax.set_ylabel("displacement (mm)")
        ax.set_title("Displacement vs temperature (cf. paper Fig. 6)")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
        fig.tight_layout()
        p = os.path.join(out_dir, "fit_displacement.png")
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)
    return written
