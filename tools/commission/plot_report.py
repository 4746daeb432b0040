#!/usr/bin/env python3
"""Plots of the commissioning report (Figs. 9-11 of the paper and more).

Reads the CSV files `clm commission` wrote into DIR and writes PNGs beside
them. Uses Debian's python3-numpy and python3-matplotlib only.
Usage: plot_report.py DIR
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

NAMES = ["original", "classical", "pgnn", "spline", "oracle"]
COLOURS = {"original": "tab:gray", "classical": "tab:blue", "pgnn": "tab:red", "spline": "tab:green",
           "oracle": "black"}


def load(path):
    return np.genfromtxt(path, delimiter=",", names=True)


def lowpass(u, period_s, cutoff_hz=50.0):
    """ZOH discretisation of 1/(s/(2*pi*f)+1): y[k] = a*y[k-1] + (1-a)*u[k-1]."""
    a = np.exp(-2 * np.pi * cutoff_hz * period_s)
    y = np.zeros_like(u)
    for k in range(1, len(u)):
        y[k] = a * y[k - 1] + (1 - a) * u[k - 1]
    return y


def error_figure(directory, steps, title, filename):
    fig, axes = plt.subplots(5, 1, figsize=(9, 10), sharex=True)
    for name in NAMES:
        path = os.path.join(directory, f"evaluation-{name}.csv")
        if not os.path.exists(path):
            continue
        d = load(path)
        mask = np.isin(d["step"], steps)
        t = d["t_s"][mask] - d["t_s"][mask][0]
        period = np.median(np.diff(d["t_s"]))
        if name == NAMES[0]:
            axes[0].plot(t, d["r_m"][mask], color="black")
        errors = [d["Fy_N"] - d["Fy_star_N"], d["Fx_N"], d["Tz_Nm"]]
        for axis, e in zip(axes[1:4], errors):
            axis.plot(t, lowpass(e, period)[mask], color=COLOURS[name], label=name, linewidth=0.8)
        axes[4].plot(t, d["e_m"][mask] * 1e6, color=COLOURS[name], label=name, linewidth=0.8)
    labels = ["reference [m]", "F_y - F_y* [N]", "F_x - F_x* [N]", "T_z - T_z* [N m]", "tracking error [µm]"]
    for axis, label in zip(axes, labels):
        axis.set_ylabel(label)
        axis.grid(True, alpha=0.3)
    axes[1].legend(loc="upper right", ncol=5, fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title + " (commutation errors low-pass filtered at 50 Hz)")
    fig.tight_layout()
    fig.savefig(os.path.join(directory, filename), dpi=110)
    plt.close(fig)


def truth_figures(directory):
    path = os.path.join(directory, "truth-comparison.csv")
    if not os.path.exists(path):
        return
    d = load(path)
    y = d["y_m"]
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    for axis, component, unit in zip(axes, ["Fy_N", "Fx_N", "Tz_Nm"], ["N", "N", "N m"]):
        axis.plot(y, d[f"cogging_true_{component}"], color="black", label="simulator truth")
        axis.plot(y, d[f"cogging_pgnn_{component}"], color=COLOURS["pgnn"], label="PGNN (35)")
        axis.plot(y, d[f"cogging_spline_{component}"], color=COLOURS["spline"], label="spline")
        axis.set_ylabel(f"{component.split('_')[0]} cogging [{unit}]")
        axis.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("position y [m]")
    fig.suptitle("Identified cogging force against the simulator's truth (paper Fig. 9)")
    fig.tight_layout()
    fig.savefig(os.path.join(directory, "cogging.png"), dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(3, 2, figsize=(11, 8), sharex=True)
    for row, direction in enumerate("yxz"):
        for col, phase in enumerate("ab"):
            entry = f"K{direction}{phase}"
            axis = axes[row][col]
            axis.plot(y, d[f"{entry}_true_1"], color="black", label="truth")
            axis.plot(y, d[f"{entry}_pgnn_1"], color=COLOURS["pgnn"], label="PGNN", linewidth=0.8)
            axis.plot(y, d[f"{entry}_spline_1"], color=COLOURS["spline"], label="spline", linewidth=0.8)
            axis.set_title(f"K^1 entry {direction},{phase}", fontsize=9)
            axis.grid(True, alpha=0.3)
    axes[0][0].legend(fontsize=8)
    axes[-1][0].set_xlabel("position y [m]")
    axes[-1][1].set_xlabel("position y [m]")
    fig.suptitle("Gain matrix of coil set 1: identified against the simulator's truth")
    fig.tight_layout()
    fig.savefig(os.path.join(directory, "gain.png"), dpi=110)
    plt.close(fig)


def tracking_figure(directory):
    fig, axis = plt.subplots(1, 1, figsize=(9, 4))
    for name in NAMES:
        path = os.path.join(directory, f"evaluation-{name}.csv")
        if os.path.exists(path):
            d = load(path)
            axis.plot(d["t_s"], d["e_m"] * 1e6, color=COLOURS[name], label=name, linewidth=0.7)
    axis.set_xlabel("time [s]")
    axis.set_ylabel("tracking error [µm]")
    axis.grid(True, alpha=0.3)
    axis.legend(ncol=5, fontsize=8)
    fig.suptitle("Tracking error on the Fig. 8 reference, each commutation with its own feedforward")
    fig.tight_layout()
    fig.savefig(os.path.join(directory, "tracking-error.png"), dpi=110)
    plt.close(fig)


def main():
    if len(sys.argv) != 2:
        print("usage: plot_report.py DIR", file=sys.stderr)
        return 2
    directory = sys.argv[1]
    error_figure(directory, [0, 1], "Slow reference, 0.025 m/s (paper Fig. 10)", "commutation-error-slow.png")
    error_figure(directory, [4, 5], "Fast reference, 0.15 m/s (paper Fig. 11)", "commutation-error-fast.png")
    truth_figures(directory)
    tracking_figure(directory)
    return 0


if __name__ == "__main__":
    sys.exit(main())
