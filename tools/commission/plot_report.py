#!/usr/bin/env python3
"""Plots of the commissioning report (Figs. 9-11 of the paper and more).

Reads what `clm commission` wrote into DIR (CSV, calibration.yaml,
report.json, logs/) and writes PNGs beside them; docs/report-format.md,
"Plots", says what each answers. The laws are those with an
evaluation-<law>.csv in DIR. Uses Debian's python3-numpy and
python3-matplotlib only.
Usage: plot_report.py DIR
"""
import glob
import json
import os
import struct
import sys
import textwrap
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402

# Known laws in the report's order; a law not listed here is plotted after them.
LAW_ORDER = ["original", "classical", "pgnn-paper", "pgnn", "spline", "classical-position", "spline-position",
             "oracle"]
LAW_COLOURS = {"original": "tab:gray", "classical": "tab:blue", "pgnn-paper": "tab:orange", "pgnn": "tab:red",
               "spline": "tab:green", "classical-position": "tab:cyan", "spline-position": "tab:purple",
               "oracle": "black"}
SPARE_COLOURS = ["tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan"]
MODEL_COLOURS = {"truth": "black", "pgnn": "tab:red", "spline": "tab:green"}
# The wrench directions: CSV column of the measured value and of the demand
# (None: the demand is 0), the mathtext name and the unit.
DIRECTIONS = [("Fy_N", "Fy_star_N", "F_y", "N"), ("Fx_N", None, "F_x", "N"), ("Tz_Nm", None, "T_z", "N m")]
IDENTIFIED_SHADE = dict(color="tab:olive", alpha=0.12, linewidth=0)
DPI = 110


# ---------------------------------------------------------------- input ----

def load_csv(path):
    """The columns of a CSV file with a header line, as a dict of float arrays."""
    with open(path) as f:
        names = f.readline().strip().split(",")
    values = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {name: values[:, k] for k, name in enumerate(names)}


def laws_present(directory, prefix):
    """The laws with a `<prefix>-<law>.csv` in DIR, known laws in the report's order."""
    found = [os.path.basename(p)[len(prefix) + 1:-4] for p in glob.glob(os.path.join(directory, f"{prefix}-*.csv"))]
    known = [law for law in LAW_ORDER if law in found]
    return known + sorted(law for law in found if law not in LAW_ORDER)


def law_colour(law):
    if law in LAW_COLOURS:
        return LAW_COLOURS[law]
    unknown = sorted(law for law in LAW_COLOURS if law not in LAW_ORDER)
    LAW_COLOURS[law] = SPARE_COLOURS[len(unknown) % len(SPARE_COLOURS)]
    return LAW_COLOURS[law]


def yaml_scalar_or_list(text):
    text = text.strip()
    if text.startswith("[") and text.endswith("]"):
        return [float(v) for v in text[1:-1].split(",") if v.strip()]
    try:
        return float(text)
    except ValueError:
        return text.strip('"')


def read_calibration(path):
    """calibration.yaml (docs/model-format.md) as far as the plots need it:
    {'pole_pitch_m', 'drive': {...}, 'coil_sets': [{...}, ...]}. The file is
    written by clm commission in a fixed layout; a line parser is enough."""
    result = {"drive": {}, "coil_sets": []}
    section = None
    with open(path) as f:
        for line in f:
            stripped = line.split("#", 1)[0].rstrip()
            if not stripped.strip():
                continue
            indent = len(stripped) - len(stripped.lstrip())
            key, _, value = stripped.strip().partition(":")
            if indent == 0:
                section = key
                continue
            if section == "motor" and key == "pole_pitch_m":
                result["pole_pitch_m"] = float(value)
            elif section == "experiment_drive_commutation":
                result["drive"][key] = float(value)
            elif section == "coil_sets":
                if key.startswith("- "):
                    result["coil_sets"].append({})
                    key = key[2:]
                result["coil_sets"][-1][key.strip()] = yaml_scalar_or_list(value)
    if "pole_pitch_m" not in result:
        raise ValueError(f"{path}: no motor.pole_pitch_m")
    return result


def read_report(directory):
    path = os.path.join(directory, "report.json")
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        return json.load(f)


# -------------------------------------------------------------- helpers ----

def lowpass(u, period_s, cutoff_hz=50.0):
    """The Table 2 filter (docs/commutation.md §11): ZOH discretisation of
    1/(s/(2*pi*f)+1), y[k] = a*y[k-1] + (1-a)*u[k-1], starting at zero."""
    a = np.exp(-2 * np.pi * cutoff_hz * period_s)
    y = np.zeros_like(u)
    for k in range(1, len(u)):
        y[k] = a * y[k - 1] + (1 - a) * u[k - 1]
    return y


def rms(values):
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else float("nan")


def direction_error(data, direction):
    measured, demand, _, _ = direction
    return data[measured] - (data[demand] if demand else 0.0)


def error_label(direction):
    _, _, name, unit = direction
    return f"${name} - {name}^*$ [{unit}]"


def shade_range(axis, range_m, label=None):
    if range_m is not None:
        axis.axvspan(range_m[0], range_m[1], label=label, **IDENTIFIED_SHADE)


def limits_within(values, mask, margin=0.15):
    """y-limits that show the values where mask holds, with a margin."""
    inside = np.concatenate([v[mask] for v in values])
    low, high = float(np.min(inside)), float(np.max(inside))
    span = max(high - low, 1e-12)
    return low - margin * span, high + margin * span


def legend_outside(axis, fontsize=8):
    """Legend to the right of the panel, where it covers no curve."""
    axis.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=fontsize, frameon=False)


def panel_grid(rows, columns, header=False, panel_size=(4.2, 1.55), sharex="all", sharey="column",
               legend_width=1.8):
    """The "one panel per law (or entry)" layout: rows x columns panels, with
    room on the right of every panel for a legend; each axis shared by "all"
    panels, by those of a "column", of a "row", or by none (None); with
    `header` an extra top row of one panel spanning every column (its x-axis
    shared with all). Returns (figure, header axis or None, 2-D axes)."""
    width = columns * (panel_size[0] + legend_width)
    height = (rows + (1 if header else 0)) * panel_size[1] + 1.0
    fig = plt.figure(figsize=(width, height))
    grid = fig.add_gridspec(rows + (1 if header else 0), columns)
    top = fig.add_subplot(grid[0, :]) if header else None
    axes = np.empty((rows, columns), dtype=object)
    for r in range(rows):
        for c in range(columns):
            first = top if top is not None else axes[0][0]
            shared = {"all": first if (r or c or top is not None) else None,
                      "column": axes[0][c] if r else None, "row": axes[r][0] if c else None}
            axes[r][c] = fig.add_subplot(grid[r + (1 if header else 0), c], sharex=shared.get(sharex),
                                         sharey=shared.get(sharey))
            axes[r][c].grid(True, alpha=0.3)
            if sharex in ("all", "column") and r < rows - 1:
                axes[r][c].tick_params(labelbottom=False)
    if top is not None:
        top.grid(True, alpha=0.3)
        if columns == 1:  # a header over several columns is wider than they are: it keeps its time labels
            top.tick_params(labelbottom=False)
    return fig, top, axes


class Progress:
    """One line per figure written: how many of the planned, and the time left
    extrapolated from the time per figure so far (the figures differ, so it is
    an estimate)."""

    def __init__(self):
        self.planned = 0
        self.done = 0
        self.start_s = time.monotonic()

    def plan(self, figures):
        self.planned, self.done, self.start_s = figures, 0, time.monotonic()

    def wrote(self, path):
        self.done += 1
        elapsed_s = time.monotonic() - self.start_s
        left = ""
        if 0 < self.done < self.planned:
            left = f", about {elapsed_s / self.done * (self.planned - self.done):.0f} s left"
        print(f"plot_report: wrote {path} ({self.done}/{max(self.planned, self.done)}, {elapsed_s:.1f} s{left})",
              flush=True)


PROGRESS = Progress()


def save(fig, directory, filename, title):
    fig.suptitle(textwrap.fill(title, int(fig.get_figwidth() * 11)))
    fig.tight_layout()
    path = os.path.join(directory, filename)
    temporary = path + ".tmp.png"
    fig.savefig(temporary, dpi=DPI)
    os.replace(temporary, path)  # a failed run never leaves half a file
    plt.close(fig)
    PROGRESS.wrote(path)


def steps_by_speed(data):
    """The program's steps grouped by their peak reference speed [m/s], slowest first."""
    speed = np.abs(np.gradient(data["r_m"], data["t_s"]))
    groups = {}
    for step in np.unique(data["step"]):
        peak = float(np.max(speed[data["step"] == step]))
        groups.setdefault(float(f"{peak:.2g}"), []).append(step)
    return sorted(groups.items())


def identified_range_m(experiments):
    """The positions the experiments covered [m]: min and max of experiments.csv y_m."""
    return float(np.min(experiments["y_m"])), float(np.max(experiments["y_m"]))


# -------------------------------------------------------------- figures ----

def commutation_error_figure(directory, laws, evaluations, which, filename):
    """One row per law, one column per direction: F - F* low-pass filtered at
    50 Hz over the slowest (or fastest) steps of the evaluation program."""
    groups = steps_by_speed(evaluations[laws[0]])
    speed, steps = groups[0] if which == "slow" else groups[-1]
    fig, top, axes = panel_grid(len(laws), len(DIRECTIONS), header=True)
    for row, law in enumerate(laws):
        d = evaluations[law]
        mask = np.isin(d["step"], steps)
        t = d["t_s"][mask] - d["t_s"][mask][0]
        if row == 0:
            top.plot(t, d["r_m"][mask], color="black", label="reference r")
            top.set_ylabel("reference r [m]")
            legend_outside(top)
        period_s = float(np.median(np.diff(d["t_s"])))
        for column, direction in enumerate(DIRECTIONS):
            filtered = lowpass(direction_error(d, direction), period_s)[mask]
            axis = axes[row][column]
            axis.plot(t, filtered, color=law_colour(law), linewidth=0.7,
                      label=f"{law}\nRMS {rms(filtered):.3g} {direction[3]}")
            axis.set_ylabel(error_label(direction))
            legend_outside(axis)
    for axis in axes[-1]:
        axis.set_xlabel("time [s]")
    only = " (the program has this one speed: the slow and fast figures show the same steps)" \
        if len(groups) == 1 else ""
    save(fig, directory, filename,
         f"Commutation error F − F* on the {which} steps (peak reference speed {speed:g} m/s{only}; "
         "low-pass filtered at 50 Hz as in Table 2)")


def tracking_figure(directory, laws, runs, filename, title):
    """Reference on top, then the tracking error of each law in a panel of its
    own (shared y-axis), RMS and the classical/law MSE ratio in each legend."""
    fig, top, axes = panel_grid(len(laws), 1, header=True, panel_size=(9.0, 1.25), legend_width=2.6)
    first = runs[laws[0]]
    top.plot(first["t_s"] - first["t_s"][0], first["r_m"], color="black", label="reference r")
    top.set_ylabel("reference r [m]")
    legend_outside(top)
    classical_mse = float(np.mean(runs["classical"]["e_m"] ** 2)) if "classical" in runs else None
    for row, law in enumerate(laws):
        d = runs[law]
        e_um = d["e_m"] * 1e6
        label = f"{law}\nRMS {rms(e_um):.3g} µm"
        if classical_mse is not None and law != "classical":
            label += f"\nMSE classical/{law} {classical_mse / np.mean(d['e_m'] ** 2):.3g}×"
        axis = axes[row][0]
        axis.plot(d["t_s"] - d["t_s"][0], e_um, color=law_colour(law), linewidth=0.6, label=label)
        axis.set_ylabel("r − y [µm]")
        legend_outside(axis)
    axes[-1][0].set_xlabel("time [s]")
    save(fig, directory, filename, title)


def tracking_psd(error, period_s, segment=4096):
    """One-sided power spectral density of `error` [unit²/Hz] by Welch's
    method (Hann windows of `segment` samples, half overlapping, each
    without its mean; one window of the whole record when it is shorter),
    and its cumulative integral over frequency [unit²]. By Parseval the
    cumulative PSD at the Nyquist frequency is the variance of the error."""
    error = np.asarray(error, dtype=float)
    n = min(segment, len(error))
    window = np.hanning(n)
    scale = 1.0 / (np.sum(window ** 2) / period_s)
    starts = range(0, len(error) - n + 1, max(n // 2, 1))
    psd = np.zeros(n // 2 + 1)
    for start in starts:
        piece = error[start:start + n]
        spectrum = np.fft.rfft((piece - np.mean(piece)) * window)
        psd += np.abs(spectrum) ** 2
    psd *= scale / len(starts)
    psd[1:(n + 1) // 2] *= 2.0  # one-sided: every bin but DC (and Nyquist for even n) twice
    frequency = np.fft.rfftfreq(n, period_s)
    df = frequency[1] - frequency[0]
    return frequency, psd, np.cumsum(psd) * df


def tracking_psd_figure(directory, laws, runs, filename):
    """The tracking error's PSD (top) and cumulative PSD (bottom) of every
    law on shared axes: where in frequency each law's error lies, and how
    much of its mean square is below each frequency."""
    fig, axes = plt.subplots(2, 1, figsize=(9.0, 6.0), sharex=True)
    for law in laws:
        d = runs[law]
        period_s = float(np.median(np.diff(d["t_s"])))
        frequency, psd, cumulative = tracking_psd(d["e_m"], period_s)
        axes[0].loglog(frequency[1:], psd[1:], color=law_colour(law), linewidth=0.7, label=law)
        axes[1].semilogx(frequency[1:], cumulative[1:], color=law_colour(law), linewidth=1.0,
                         label=f"{law}: variance {cumulative[-1]:.3g} m²")
    axes[0].set_ylabel("PSD of r − y [m²/Hz]")
    axes[1].set_ylabel("cumulative PSD [m²]")
    axes[1].set_yscale("log")
    axes[1].set_xlabel("frequency [Hz]")
    legend_outside(axes[0])
    legend_outside(axes[1])
    save(fig, directory, filename,
         "Tracking error r − y on the evaluation reference: power spectral density and its cumulative integral "
         "(Welch, 4.1 s Hann windows; the cumulative value at the right end is the error's variance)")


def position_error_figure(directory, laws, evaluations, pole_pitch_m, range_m, filename, bin_m=0.25e-3):
    """Per law: the driving-direction error F_y - F_y* averaged in position bins
    over the whole evaluation run, and its amplitude spectrum over spatial
    frequency with the multiples of 1/pole pitch marked."""
    fig, _, axes = panel_grid(len(laws), 2, sharex="column")
    harmonics_shown = 12
    for row, law in enumerate(laws):
        d = evaluations[law]
        error = direction_error(d, DIRECTIONS[0])
        edges = np.arange(np.min(d["y_m"]), np.max(d["y_m"]) + bin_m, bin_m)
        index = np.clip(np.digitize(d["y_m"], edges) - 1, 0, len(edges) - 2)
        counts = np.bincount(index, minlength=len(edges) - 1)
        sums = np.bincount(index, weights=error, minlength=len(edges) - 1)
        centres = 0.5 * (edges[:-1] + edges[1:])
        filled = counts > 0
        mean = np.interp(centres, centres[filled], sums[filled] / counts[filled])
        axis = axes[row][0]
        shade_range(axis, range_m, "identified range" if row == 0 else None)
        axis.plot(centres, mean, color=law_colour(law), linewidth=0.7,
                  label=f"{law}\nRMS {rms(mean):.3g} N\n(bin means)")
        axis.set_ylabel(r"$F_y - F_y^*$ [N]")
        legend_outside(axis)
        # Hann window; 2/sum(w) makes a sinusoid of amplitude A read A.
        window = np.hanning(len(mean))
        amplitude = 2.0 * np.abs(np.fft.rfft((mean - np.mean(mean)) * window)) / np.sum(window)
        frequency = np.fft.rfftfreq(len(mean), bin_m)
        axis = axes[row][1]
        for k in range(1, harmonics_shown + 1):
            axis.axvline(k / pole_pitch_m, color="tab:purple", alpha=0.5, linewidth=0.9,
                         label=f"k / pole pitch,\nk = 1..{harmonics_shown}" if k == 1 and row == 0 else None)
        axis.semilogy(frequency, amplitude, color=law_colour(law), linewidth=0.8, label=f"{law} spectrum")
        axis.set_xlim(0, (harmonics_shown + 0.5) / pole_pitch_m)
        axis.set_ylabel("amplitude [N]")
        legend_outside(axis)
    axes[-1][0].set_xlabel("position y [m]")
    axes[-1][1].set_xlabel(f"spatial frequency [1/m] (1 / pole pitch = {1 / pole_pitch_m:.4g} 1/m)")
    save(fig, directory, filename,
         f"Driving-direction commutation error against position (evaluation run, {bin_m * 1e3:g} mm bins) "
         f"and its spectrum; pole pitch {pole_pitch_m * 1e3:g} mm")


def truth_grid_figure(directory, truth, range_m, entries, filename, title, error=False):
    """Identified against the simulator's truth on the truth-comparison grid,
    one panel per entry (rows) and coil set (columns, y-axis shared along a
    row): the functions themselves, or (error=True) identified - truth with
    its RMS over the identified range. The y-axis shows the identified range;
    what the models do outside it is clipped, and the legend says how far it
    goes. `entries` is [(row label, [(prefix, suffix)] per column, unit)];
    the columns read are <prefix>_<true|pgnn|spline><suffix>."""
    y = truth["y_m"]
    inside = (y >= range_m[0]) & (y <= range_m[1]) if range_m is not None else np.ones_like(y, dtype=bool)
    columns = len(entries[0][1])
    fig, _, axes = panel_grid(len(entries), columns, sharey="row", panel_size=(4.0 if columns > 1 else 5.5, 1.7),
                              legend_width=2.0)
    for row, (label, cells, unit) in enumerate(entries):
        row_curves = []
        for column, (prefix, suffix) in enumerate(cells):
            axis = axes[row][column]
            shade_range(axis, range_m, "identified range")
            true = truth[f"{prefix}_true{suffix}"]
            curves = [] if error else [("truth", true)]
            curves += [(model, truth[f"{prefix}_{model}{suffix}"] - (true if error else 0.0))
                       for model in ("pgnn", "spline")]
            for model, values in curves:
                text = f"{model}, RMS in range {rms(values[inside]):.2g} {unit}" if error else model
                axis.plot(y, values, color=MODEL_COLOURS[model], linewidth=1.6 if model == "truth" else 1.0,
                          linestyle={"truth": "-", "pgnn": "--", "spline": ":"}[model] if not error else "-",
                          label=text)
            row_curves += [values for _, values in curves]
            axis.set_ylabel(f"{label} error [{unit}]" if error else f"{label} [{unit}]")
            if row == 0 and columns > 1:
                axis.set_title(f"coil set {column + 1}", fontsize=9)
        low, high = limits_within(row_curves, inside)
        axes[row][0].set_ylim(low, high)
        for column, axis in enumerate(axes[row]):
            # How far a model goes beyond the limits outside the identified range, in the legend.
            for line in axis.get_lines():
                if line.get_label().split(",")[0] not in ("pgnn", "spline"):
                    continue
                values = line.get_ydata()[~inside]
                if len(values) and (np.max(values) > high or np.min(values) < low):
                    far = values[np.argmax(np.abs(values))]
                    axis.plot([], [], " ", label=f"{line.get_label().split(',')[0]} reaches {far:.3g} {unit}\n"
                                                 "outside the range (clipped)")
            legend_outside(axis, fontsize=7)
    for axis in axes[-1]:
        axis.set_xlabel("position y [m]")
        axis.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(6))
    save(fig, directory, filename, title)


def truth_figures(directory, range_m):
    path = os.path.join(directory, "truth-comparison.csv")
    if not os.path.exists(path):
        print("plot_report: no truth-comparison.csv (live commissioning): cogging and gain plots skipped")
        return
    truth = load_csv(path)
    # Columns <prefix>_<model><suffix>: cogging_true_Fy_N, Kya_pgnn_1, ...
    cogging = [(f"${name}$ cogging", [("cogging", f"_{column}")], unit) for column, _, name, unit in DIRECTIONS]
    for error, filename, what in ((False, "cogging.png", "Identified cogging wrench against the simulator's truth "
                                   "(paper Fig. 9)"),
                                  (True, "cogging-error.png", "Cogging wrench: identified − truth")):
        truth_grid_figure(directory, truth, range_m, cogging, filename, what, error)
    coil_sets = sorted({int(key.rsplit("_", 1)[1]) for key in truth if key.startswith("Kya_true_")})
    units = {"y": "N/A", "x": "N/A", "z": "N m/A"}
    entries = [(f"$K^{{l}}_{{{direction},{phase}}}$", [(f"K{direction}{phase}", f"_{l}") for l in coil_sets],
                units[direction]) for direction in "yxz" for phase in "ab"]
    for error, filename, what in ((False, "gain.png", "Gain matrix entries $K^l_{d,p}$ (current [A] of phase p "
                                   "→ force in direction d) of every coil set l, identified against the truth"),
                                  (True, "gain-error.png", "Gain matrix entries: identified − truth")):
        truth_grid_figure(directory, truth, range_m, entries, filename, what, error)


def calibration_figure(directory, calibration, data, filename):
    """Algorithm 1 per coil set (columns): measured F_y against the commanded
    magnitude for each phase offset, with the fitted ratio c_i (eq. 14) as a
    line; below, c against the offset with the cosine
    (k/k_drive)*cos(zeta - zeta_drive - delta) that the fitted k and zeta
    imply (eq. 15), through the two measured ratios. `data` is experiments.csv."""
    drive_k = calibration["drive"]["motor_constant_N_per_A"]
    drive_zeta = calibration["drive"]["phase_offset_rad"]
    sets = calibration["coil_sets"]
    fig, _, axes = panel_grid(2, len(sets), sharex=None, sharey=None, panel_size=(3.9, 3.0), legend_width=0.3)
    offset_colours = ["tab:blue", "tab:orange"]
    delta_axis = np.linspace(-np.pi, np.pi, 361)
    for column, entry in enumerate(sets):
        rows = data["coil_set"] == column + 1
        k_hat, zeta_hat = entry["motor_constant_N_per_A"], entry["phase_offset_rad"]
        axis = axes[0][column]
        for g, delta in enumerate(entry["delta_rad"]):
            group = rows & (np.abs(data["delta_rad"] - delta) < 1e-9)
            magnitude, force = data["magnitude_N"][group], data["Fy_N"][group]
            ratio = entry["gain_ratio"][g]
            axis.plot(magnitude, force, ".", markersize=1, alpha=0.15, color=offset_colours[g], rasterized=True)
            line = np.array([np.min(magnitude), np.max(magnitude)])
            axis.plot(line, ratio * line, color=offset_colours[g], linewidth=1.5,
                      label=rf"$\Delta$ = {delta:+.3f} rad: $\hat c$ = {ratio:.3f}"
                            f"\nresidual RMS {entry['residual_rms_N'][g]:.2g} N")
        axis.set_xlabel(r"commanded magnitude $F_y^*$ [N]")
        axis.set_ylabel(r"measured $F_y$ [N]")
        axis.set_title(f"coil set {column + 1}", fontsize=9)
        axis.legend(fontsize=7, loc="upper left")
        axis = axes[1][column]
        axis.plot(delta_axis, k_hat / drive_k * np.cos(zeta_hat - drive_zeta - delta_axis), color="black",
                  linewidth=1, label=rf"fit: $\hat k$ = {k_hat:.4g} N/A" "\n" rf"$\hat\zeta$ = {zeta_hat:.4g} rad")
        for g, delta in enumerate(entry["delta_rad"]):
            axis.plot(delta, entry["gain_ratio"][g], "o", color=offset_colours[g])
        axis.axvline(zeta_hat - drive_zeta, color="gray", linestyle=":",
                     label=r"peak: $\Delta = \hat\zeta - \hat\zeta_{drive}$")
        axis.set_xlabel(r"phase offset $\Delta$ [rad]")
        axis.set_ylabel(r"force ratio $\hat c = F_y / F_y^*$ [–]")
        axis.legend(fontsize=7, loc="lower center")
    save(fig, directory, filename,
         rf"Calibration (Algorithm 1, eqs. 14-15): the drive's $\hat k$ = {drive_k:g} N/A, "
         rf"$\hat\zeta$ = {drive_zeta:g} rad, corrected per coil set")


# LCM servo_status_t as far as the timing fields (lcmtypes/servo_status_t.lcm);
# only messages with the fingerprint report.json names (live.status_fingerprint,
# written by the clm that recorded them) are decoded.
LCM_SYNC = 0xEDA1DA01


def lcm_events(path, channel):
    """The payloads of one channel of an LCM log file."""
    with open(path, "rb") as f:
        blob = f.read()
    offset = 0
    while offset + 28 <= len(blob):
        sync, _, _, channel_length, data_length = struct.unpack_from(">IqqII", blob, offset)
        if sync != LCM_SYNC:
            raise ValueError(f"{path}: bad LCM sync word at byte {offset}")
        start = offset + 28 + channel_length
        if blob[offset + 28:start].decode(errors="replace") == channel:
            yield blob[start:start + data_length]
        offset = start + data_length


HISTOGRAM_BINS = 31  # servo_status_t.wakeup_latency_histogram, compute_time_histogram


def histogram_upper_edges_s():
    """Upper edges of the status message's histogram bins [s]: bin j holds
    (1e-7 10^((j-1)/5), 1e-7 10^(j/5)] s, the last bin everything beyond."""
    edges = 1e-7 * 10.0 ** (np.arange(HISTOGRAM_BINS) / 5.0)
    edges[-1] = np.inf
    return edges


def status_timing(payload, fingerprint):
    """The loop-timing fields of one servo_status_t whose type has
    `fingerprint` (8 bytes): utime [us], session, (wake-up latency p50, p99,
    max, compute time p50, p99, max) [s], overruns, cycles and the two
    cumulative histograms."""
    if payload[:8] != fingerprint:
        raise ValueError(f"a CLM_SERVO_STATUS with fingerprint {payload[:8].hex()}, not report.json's "
                         f"{fingerprint.hex()}: logs of another clm-servo version")
    offset = 8

    def read(fmt):
        nonlocal offset
        values = struct.unpack_from(fmt, payload, offset)
        offset += struct.calcsize(fmt)
        return values

    def skip_string():
        nonlocal offset
        offset += 4 + struct.unpack_from(">i", payload, offset)[0]

    utime, = read(">q")
    skip_string()                                # axis
    session, _state, _fault = read(">qbh")
    skip_string()                                # fault_reason
    read(">qb")                                  # fault_cycle, commutation
    for _ in range(12):                          # the files and their SHA-256
        skip_string()
    quantiles = read(">6d")
    overruns, cycles = read(">qq")
    wakeup = np.array(read(f">{HISTOGRAM_BINS}q"), dtype=np.int64)
    compute = np.array(read(f">{HISTOGRAM_BINS}q"), dtype=np.int64)
    return {"utime": utime, "session": session, "quantiles": quantiles, "overruns": overruns, "cycles": cycles,
            "wakeup": wakeup, "compute": compute}


def histogram_quantile_text(counts, q):
    """'≤ upper edge' of the bin holding quantile q of a status histogram, in µs."""
    cumulative = np.cumsum(counts)
    if cumulative[-1] == 0:
        return "n/a (no cycles)"
    edges_s = histogram_upper_edges_s()
    bin_index = int(np.searchsorted(cumulative, max(1, np.ceil(q * cumulative[-1]))))
    if bin_index == HISTOGRAM_BINS - 1:
        return f"> {edges_s[-2] * 1e6:.3g} µs"
    return f"≤ {edges_s[bin_index] * 1e6:.3g} µs"


def logged_cycle_histograms(samples):
    """The histograms of the cycles the logs span: per daemon session, the
    last status's cumulative counts minus the first's, summed over sessions."""
    wakeup = np.zeros(HISTOGRAM_BINS, dtype=np.int64)
    compute = np.zeros(HISTOGRAM_BINS, dtype=np.int64)
    for session in {s["session"] for s in samples}:
        mine = sorted((s for s in samples if s["session"] == session), key=lambda s: s["cycles"])
        wakeup += mine[-1]["wakeup"] - mine[0]["wakeup"]
        compute += mine[-1]["compute"] - mine[0]["compute"]
    return wakeup, compute


def latency_figure(directory, report, filename):
    """The loop's wake-up latency and compute time over a live commissioning:
    histograms of the cycles between the first and the last logged status
    of each daemon session (the status messages carry cumulative counts),
    and the overruns over time."""
    if "live" not in report:
        print(f"plot_report: {filename} skipped: the in-process commissioning runs on a virtual clock, so the "
              "loop has no wake-up latency to show (the status messages carry zeros); made with --live only")
        return
    samples = []
    fingerprint = bytes.fromhex(report["live"].get("status_fingerprint", ""))
    for path in sorted(glob.glob(os.path.join(directory, "logs", "*.lcm"))):
        for payload in lcm_events(path, "CLM_SERVO_STATUS"):
            try:
                samples.append(status_timing(payload, fingerprint))
            except (ValueError, struct.error) as error:
                print(f"plot_report: {filename} skipped: {path}: {error}")
                return
    wakeup, compute = logged_cycle_histograms(samples) if samples else (np.zeros(1), np.zeros(1))
    if wakeup.sum() == 0:
        print(f"plot_report: {filename} skipped: the logs' CLM_SERVO_STATUS messages span no timed cycle")
        return
    samples.sort(key=lambda s: s["utime"])
    edges_s = histogram_upper_edges_s()
    lower_s = np.concatenate(([edges_s[0] / 10 ** 0.2], edges_s[:-1]))
    upper_s = np.concatenate((edges_s[:-1], [edges_s[-2] * 10 ** 0.2]))  # the last bin drawn one bin wide
    fig, _, axes = panel_grid(3, 1, sharex=None, sharey=None, panel_size=(9.0, 2.1), legend_width=2.8)
    cycles = int(wakeup.sum())
    for axis, counts, name in ((axes[0][0], wakeup, "wake-up latency"), (axes[1][0], compute, "compute time")):
        first, last = np.flatnonzero(counts > 0)[[0, -1]]
        first, last = max(first - 1, 0), min(last + 1, HISTOGRAM_BINS - 1)  # an empty bin either side
        # Log counts: a bar starts at 0.5, below one cycle, so a single cycle shows.
        axis.bar(lower_s[first:last + 1] * 1e6, counts[first:last + 1], bottom=0.5,
                 width=(upper_s - lower_s)[first:last + 1] * 1e6, align="edge", edgecolor="black", linewidth=0.4,
                 label=f"{int(counts.sum())} cycles\n" + "\n".join(
                     f"{name_q} {histogram_quantile_text(counts, q)}"
                     for name_q, q in (("p50", 0.5), ("p99", 0.99), ("p99.9", 0.999))))
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xlim(lower_s[first] * 1e6, upper_s[last] * 1e6)
        axis.set_ylim(0.5, None)
        axis.set_xlabel(f"{name} [µs] (5 bins a decade)")
        axis.set_ylabel("cycles [–]")
        legend_outside(axis)
    t = np.array([(s["utime"] - samples[0]["utime"]) * 1e-6 for s in samples])
    overruns = np.array([s["overruns"] for s in samples])
    axes[2][0].plot(t, overruns, ".", markersize=2, color="tab:red",
                    label=f"overruns: {int(overruns[0])} at the first,\n{int(overruns[-1])} at the last "
                          "logged status")
    axes[2][0].set_ylabel("overruns since start [–]")
    axes[2][0].set_xlabel("wall-clock time since the first logged status message [s] (gaps: between runs)")
    legend_outside(axes[2][0])
    print(f"plot_report: {filename}: {cycles} cycles in the logged runs, wake-up latency p99 "
          f"{histogram_quantile_text(wakeup, 0.99)}, compute time p99 {histogram_quantile_text(compute, 0.99)}")
    save(fig, directory, filename,
         f"Loop timing of clm-servod during live commissioning: histograms of the {cycles} cycles between the "
         f"first and the last status message of each daemon session in logs/*.lcm ({len(samples)} messages), "
         "and the overruns since the daemon started")


def main():
    if len(sys.argv) == 2 and sys.argv[1] in ("-h", "--help"):
        print(__doc__.strip())
        return 0
    if len(sys.argv) != 2:
        print("usage: plot_report.py DIR  (the output directory of clm commission)", file=sys.stderr)
        return 2
    try:
        return plot_all(sys.argv[1])
    except (OSError, ValueError, KeyError, IndexError) as error:
        # A missing file, a malformed CSV or YAML, a missing column: one line, no traceback.
        print(f"plot_report: error: {sys.argv[1]}: {type(error).__name__}: {error}", file=sys.stderr)
        return 1


def plot_all(directory):
    """Every plot for the output directory of clm commission; 0, or 1 when there is nothing to plot."""
    laws = laws_present(directory, "evaluation")
    if not laws:
        print(f"plot_report: error: no evaluation-<law>.csv in {directory}", file=sys.stderr)
        return 1
    report = read_report(directory)
    calibration = read_calibration(os.path.join(directory, "calibration.yaml"))
    experiments = load_csv(os.path.join(directory, "experiments.csv"))
    range_m = identified_range_m(experiments)
    evaluations = {law: load_csv(os.path.join(directory, f"evaluation-{law}.csv")) for law in laws}
    held_out = laws_present(directory, "validation")
    truth = os.path.exists(os.path.join(directory, "truth-comparison.csv"))
    # commutation error slow and fast, tracking, its PSD, position error,
    # calibration; validation; cogging, its error, gain, its error; latency (live runs).
    PROGRESS.plan(6 + bool(held_out) + 4 * truth + (not truth))
    for which in ("slow", "fast"):
        commutation_error_figure(directory, laws, evaluations, which, f"commutation-error-{which}.png")
    tracking_figure(directory, laws, evaluations, "tracking-error.png",
                    "Tracking error on the evaluation reference, each law with its own feedforward (40)")
    tracking_psd_figure(directory, laws, evaluations, "tracking-psd.png")
    position_error_figure(directory, laws, evaluations, calibration["pole_pitch_m"], range_m, "position-error.png")
    del evaluations
    if held_out:
        runs = {law: load_csv(os.path.join(directory, f"validation-{law}.csv")) for law in held_out}
        tracking_figure(directory, held_out, runs, "validation.png",
                        "Held-out trajectory (used for neither identification nor feedforward): tracking error")
    else:
        print("plot_report: no validation-<law>.csv (--validation-program none): validation.png skipped")
    truth_figures(directory, range_m)
    calibration_figure(directory, calibration, experiments, "calibration.png")
    latency_figure(directory, report, "latency.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
