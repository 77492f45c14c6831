#!/usr/bin/env python3
"""Plots of a discrepancy run (called by sma_discrepancy): reads DIR/trace.csv and
DIR/analysis.json, writes DIR/fit.png, DIR/residuals.png, DIR/loops.png and
DIR/residual_states.png (the residual left against the model's states, report.json "residual_analysis")."""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(out: str) -> int:
    tr = np.genfromtxt(os.path.join(out, "trace.csv"), delimiter=",", names=True)
    with open(os.path.join(out, "analysis.json")) as f:
        an = json.load(f)
    with open(os.path.join(out, "report.json")) as f:
        rep = json.load(f)
    t = tr["t_s"]
    named = ", ".join(e["name"] for e in rep["effects"]) or "nothing added"

    fig, ax = plt.subplots(2, 1, figsize=(11, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    ax[0].plot(t, tr["d_mm"], color="0.3", lw=1.2, label="measured")
    ax[0].plot(t, tr["d_nominal_mm"], "--", color="tab:red", lw=1, label=f"paper's model (RMS {rep['rms_mm_nominal']:.4f} mm)")
    ax[0].plot(t, tr["d_corrected_mm"], color="tab:blue", lw=1, label=f"+ {named} (RMS {rep['rms_mm_final']:.4f} mm)")
    ax[0].set_ylabel("displacement, mm")
    ax[0].legend(loc="best", fontsize=8)
    ax[0].set_title("Measured vs nominal vs corrected model")
    ax[1].plot(t, tr["v_V"], color="tab:orange", lw=1)
    ax[1].set_ylabel("V")
    ax[1].set_xlabel("time, s")
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fit.png"), dpi=90)
    plt.close(fig)

    fig, ax = plt.subplots(3, 1, figsize=(11, 8))
    ax[0].plot(t, tr["d_mm"] - tr["d_nominal_mm"], color="tab:red", lw=0.8, label="paper's model")
    ax[0].plot(t, tr["d_mm"] - tr["d_corrected_mm"], color="tab:blue", lw=0.8, label="corrected")
    ax[0].set_ylabel("measured - model, mm")
    ax[0].set_xlabel("time, s")
    ax[0].legend(fontsize=8)
    ax[0].set_title("Residuals before and after")
    dt = an["dt_s"]
    lags = np.arange(len(an["autocorr_before"])) * dt
    ax[1].plot(lags, an["autocorr_before"], color="tab:red", label="before")
    ax[1].plot(lags, an["autocorr_after"], color="tab:blue", label="after")
    ax[1].set_ylabel("autocorrelation")
    ax[1].set_xlabel("lag, s")
    ax[1].legend(fontsize=8)
    xl = an["xcorr_v_min_lag_s"] + np.arange(len(an["xcorr_v_before"])) * dt
    ax[2].plot(xl, an["xcorr_v_before"], color="tab:red", label="before")
    ax[2].plot(xl, an["xcorr_v_after"], color="tab:blue", label="after")
    ax[2].set_ylabel("corr(residual, V)")
    ax[2].set_xlabel("lag of V, s")
    ax[2].legend(fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "residuals.png"), dpi=90)
    plt.close(fig)

    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    ax[0].plot(tr["T_nominal_C"], tr["d_mm"], color="0.3", lw=0.8, label="measured")
    ax[0].plot(tr["T_nominal_C"], tr["d_nominal_mm"], "--", color="tab:red", lw=1, label="paper's model")
    ax[0].set_title("against the paper's model temperature")
    ax[1].plot(tr["T_corrected_C"], tr["d_mm"], color="0.3", lw=0.8, label="measured")
    ax[1].plot(tr["T_corrected_C"], tr["d_corrected_mm"], color="tab:blue", lw=1, label="corrected")
    ax[1].set_title("against the corrected model temperature")
    ax[0].set_ylabel("displacement, mm")
    for a in ax:
        a.set_xlabel("model wire temperature, °C")
        a.legend(fontsize=8)
        a.grid(alpha=0.3)
    fig.suptitle("Hysteresis loops")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "loops.png"), dpi=90)
    plt.close(fig)
    ra = rep.get("residual_analysis")
    if ra and ra["states"]:
        fig, axs = plt.subplots(2, 3, figsize=(12, 6.5))
        for a, st in zip(axs.flat, ra["states"]):
            a.plot(st["bin_state"], st["bin_mean_mm"], "o-", color="tab:purple")
            a.axhline(0, color="0.5", lw=0.8)
            a.set_xlabel(f"{st['state']} ({st['unit']})")
            a.set_ylabel("mean residual, mm")
            a.set_title(f"R² binned {st['r2_binned']:.2f}, line {st['r2_linear']:.2f}", fontsize=9)
            a.grid(alpha=0.3)
        head = "the vocabulary does not explain this log: " if ra.get("no_credible_candidate") else ""
        fig.suptitle(f"{head}residual left (RMS {ra['rms_mm']:.4f} mm) against the model's states"
                     + (f"; follows {ra['follows']}" if ra["follows"] else ""))
        fig.tight_layout()
        fig.savefig(os.path.join(out, "residual_states.png"), dpi=90)
        plt.close(fig)
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print("usage: plot_discrepancy.py DIR", file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
