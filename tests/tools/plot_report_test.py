#!/usr/bin/env python3
"""plot_report.py on a small synthetic commissioning directory.

Usage: plot_report_test.py PLOT_REPORT_PY WORK_DIR

Two directories, made here from sine waves (no clm run): an in-process one
with four laws (one of them a name the plotter does not know), two coil
sets and the truth comparison; and a "live" one with three laws, no truth
comparison, no held-out runs, and an LCM log whose status messages carry
loop timing. Checks that every expected PNG is written and not empty, that
nothing else is, and that the skipped plots say why.
"""
import json
import os
import shutil
import struct
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from lcm_wire import corpus_hash  # noqa: E402  (lcm-gen's fingerprint, from the fuzz corpus)

POLE_PITCH_M = 0.03
STATUS_FINGERPRINT = corpus_hash("status-fault")  # what clm writes as report.json's live.status_fingerprint


def write_csv(path, columns):
    names = list(columns)
    np.savetxt(path, np.column_stack([columns[n] for n in names]), delimiter=",", header=",".join(names),
               comments="")


def program(seconds=3.0, period_s=0.001):
    """Two steps on [-0.05, 0.05] m: slowly out over half the time, fast back, then at rest."""
    t = np.arange(0.0, seconds, period_s)
    half_s = seconds / 2
    back = np.maximum(0.05 - 0.1 * (t - half_s) / (0.3 * seconds), -0.05)
    r = np.where(t < half_s, -0.05 + 0.1 * t / half_s, back)
    return t, r, (t >= half_s).astype(float)


def run_columns(law_index, rng):
    t, r, step = program()
    y = r - 1e-7 * (law_index + 1) * np.sin(2 * np.pi * r / POLE_PITCH_M)
    f_star = 20 * np.sin(3 * t)
    ripple = (law_index + 1) * 0.5 * np.sin(2 * np.pi * y / POLE_PITCH_M)
    return {"t_s": t, "step": step, "r_m": r, "y_m": y, "e_m": r - y, "F_star_N": f_star, "u_ff_N": f_star,
            "Fy_star_N": f_star, "Fy_N": f_star + ripple + rng.normal(0, 0.1, len(t)),
            "Fx_N": rng.normal(0, 0.1, len(t)), "Tz_Nm": rng.normal(0, 0.05, len(t)),
            "current_square_sum_A2": np.ones_like(t)}


def calibration_yaml(coil_sets):
    lines = ["format: clm-servo-calibration", "format_version: 1", "method: algorithm1", "motor:",
             f"  pole_pitch_m: {POLE_PITCH_M}", f"  coil_sets: {coil_sets}", "experiment_drive_commutation:",
             "  motor_constant_N_per_A: 60", "  phase_offset_rad: -0.5", "coil_sets:"]
    for _ in range(coil_sets):
        lines += ["  - motor_constant_N_per_A: 55.5", "    phase_offset_rad: -0.55",
                  "    delta_rad: [-0.78539816339744828, 0.78539816339744828]",
                  "    gain_ratio: [0.62, 0.6]", "    residual_rms_N: [4.8, 4.9]"]
    return "\n".join(lines) + "\n"


def experiments(coil_sets, rng):
    columns = {k: [] for k in ("t_s", "coil_set", "delta_rad", "magnitude_N", "y_m", "Fy_N", "Fx_N", "Tz_Nm")}
    for coil_set in range(1, coil_sets + 1):
        for delta, ratio in ((-np.pi / 4, 0.62), (np.pi / 4, 0.6)):
            t, r, _ = program(1.0)
            magnitude = 30 * np.sin(5 * t)
            for name, values in (("t_s", t), ("coil_set", np.full_like(t, coil_set)),
                                 ("delta_rad", np.full_like(t, delta)), ("magnitude_N", magnitude), ("y_m", r),
                                 ("Fy_N", ratio * magnitude + rng.normal(0, 1, len(t))),
                                 ("Fx_N", np.zeros_like(t)), ("Tz_Nm", np.zeros_like(t))):
                columns[name].append(values)
    return {k: np.concatenate(v) for k, v in columns.items()}


def truth_comparison(coil_sets):
    y = np.arange(-0.06, 0.06 + 1e-9, 0.00025)
    columns = {"y_m": y}
    for model, wrong in (("true", 0.0), ("pgnn", 0.02), ("spline", -0.02)):
        for component in ("Fy_N", "Fx_N", "Tz_Nm"):
            columns[f"cogging_{model}_{component}"] = np.sin(2 * np.pi * y / POLE_PITCH_M * 6) * (1 + wrong)
    for coil_set in range(1, coil_sets + 1):
        for model, wrong in (("true", 0.0), ("pgnn", 0.01), ("spline", -0.01)):
            for direction in "yxz":
                for phase, shift in (("a", 0.0), ("b", 2.1)):
                    columns[f"K{direction}{phase}_{model}_{coil_set}"] = \
                        60 * np.cos(2 * np.pi * y / POLE_PITCH_M + shift) * (1 + wrong) + 500 * wrong * (y > 0.05)
    return columns


def lcm_string(text):
    data = text.encode() + b"\0"
    return struct.pack(">i", len(data)) + data


def status_message(k, session):
    """A servo_status_t as far as the fields the plotter reads, with loop
    timing: 100 cycles a message, 90 of them with a wake-up latency in
    (15.8, 25.1] us (bin 12) and 10 in (631, 1000] us (bin 20), compute
    time in (2.51, 3.98] us (bin 8); the counters start from 10^6 cycles run before."""
    payload = STATUS_FINGERPRINT + struct.pack(">q", 1_800_000_000_000_000 + k * 100_000) + lcm_string("axis0")
    payload += struct.pack(">qbh", session, 1, 0) + lcm_string("") + struct.pack(">qb", -1, 2)
    payload += b"".join(lcm_string("") for _ in range(12))
    latency_s = 20e-6 * (1 + (k % 7))
    cycles = 1_000_000 + 100 * k
    wakeup, compute = [0] * 31, [0] * 31
    wakeup[12], wakeup[20], compute[8] = cycles - cycles // 10, cycles // 10, cycles
    payload += struct.pack(">6dqq", latency_s, 2 * latency_s, 5 * latency_s, 8e-6, 12e-6, 30e-6, 0, cycles)
    payload += struct.pack(">31q", *wakeup) + struct.pack(">31q", *compute)
    return payload


def lcm_log(path, payloads):
    with open(path, "wb") as f:
        for number, payload in enumerate(payloads):
            channel = b"CLM_SERVO_STATUS"
            f.write(struct.pack(">IqqII", 0xEDA1DA01, number, number * 100_000, len(channel), len(payload)))
            f.write(channel + payload)


def make_directory(directory, laws, held_out, coil_sets, truth, live):
    shutil.rmtree(directory, ignore_errors=True)
    os.makedirs(os.path.join(directory, "logs"))
    rng = np.random.default_rng(1)
    for index, law in enumerate(laws):
        write_csv(os.path.join(directory, f"evaluation-{law}.csv"), run_columns(index, rng))
    for index, law in enumerate(held_out):
        write_csv(os.path.join(directory, f"validation-{law}.csv"), run_columns(index, rng))
    write_csv(os.path.join(directory, "experiments.csv"), experiments(coil_sets, rng))
    with open(os.path.join(directory, "calibration.yaml"), "w") as f:
        f.write(calibration_yaml(coil_sets))
    if truth:
        write_csv(os.path.join(directory, "truth-comparison.csv"), truth_comparison(coil_sets))
    report = {"schema": "clm-servo-report", "schema_version": 1, "coil_sets": coil_sets}
    if live:
        report["live"] = {"runs": 1, "status_fingerprint": STATUS_FINGERPRINT.hex()}
        # Two daemon sessions, 50 and 20 status messages: 49 * 100 + 19 * 100 cycles between their first and last.
        lcm_log(os.path.join(directory, "logs", "evaluation-pgnn.lcm"), [status_message(k, 7) for k in range(50)])
        lcm_log(os.path.join(directory, "logs", "evaluation-spline.lcm"), [status_message(k, 8) for k in range(20)])
    with open(os.path.join(directory, "report.json"), "w") as f:
        json.dump(report, f)


def check(script, directory, expected, said):
    result = subprocess.run([sys.executable, script, directory], capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"FAIL: plot_report.py {directory}: exit {result.returncode}\n{result.stderr}")
    written = sorted(name for name in os.listdir(directory) if name.endswith(".png"))
    if written != sorted(expected):
        sys.exit(f"FAIL: {directory}: wrote {written}, expected {sorted(expected)}")
    for name in written:
        if os.path.getsize(os.path.join(directory, name)) < 10_000:
            sys.exit(f"FAIL: {directory}/{name} is nearly empty")
    for text in said:
        if text not in result.stdout:
            sys.exit(f"FAIL: plot_report.py {directory} did not say '{text}':\n{result.stdout}")
    leftovers = [name for name in os.listdir(directory) if ".tmp" in name]
    if leftovers:
        sys.exit(f"FAIL: {directory}: temporary files left: {leftovers}")
    print(f"plot_report.py {os.path.basename(directory)}: {len(written)} plots: {', '.join(written)}")


def check_psd(script):
    """tracking_psd against analytic values: a sine of amplitude A puts A²/2
    into the cumulative PSD within a few bins of its frequency; white noise
    of variance σ² spreads σ² evenly; their sum ends at A²/2 + σ² (Parseval)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("plot_report", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    period_s, amplitude, sigma, f0 = 1e-3, 2e-6, 1e-6, 37.0
    t = np.arange(0.0, 60.0, period_s)
    noise = np.random.default_rng(5).normal(0.0, sigma, t.size)
    frequency, psd, cumulative = module.tracking_psd(amplitude * np.sin(2 * np.pi * f0 * t) + noise, period_s)
    df = frequency[1] - frequency[0]
    below = cumulative[np.searchsorted(frequency, f0 - 3 * df)]
    above = cumulative[np.searchsorted(frequency, f0 + 3 * df)]
    line = above - below - sigma ** 2 * 6 * df / frequency[-1]
    total = amplitude ** 2 / 2 + sigma ** 2
    if abs(line / (amplitude ** 2 / 2) - 1) > 0.02:
        sys.exit(f"FAIL: tracking_psd: the sine's line holds {line:.4g} m², expected {amplitude ** 2 / 2:.4g} (2 %)")
    if abs(cumulative[-1] / total - 1) > 0.02:
        sys.exit(f"FAIL: tracking_psd: the cumulative PSD ends at {cumulative[-1]:.4g} m², "
                 f"expected A²/2 + σ² = {total:.4g} (2 %)")
    flat = psd[(frequency > 100) & (frequency < 400)]
    if abs(np.mean(flat) / (2 * sigma ** 2 * period_s) - 1) > 0.05:
        sys.exit(f"FAIL: tracking_psd: white noise's level {np.mean(flat):.4g} m²/Hz, expected 2σ²T = "
                 f"{2 * sigma ** 2 * period_s:.4g} (5 %)")
    print(f"tracking_psd: the sine's line {line:.4g} m² (A²/2 {amplitude ** 2 / 2:.4g}), total {cumulative[-1]:.4g} m² "
          f"(A²/2 + σ² {total:.4g})")


def main():
    script, work = sys.argv[1], sys.argv[2]
    check_psd(script)
    always = ["commutation-error-slow.png", "commutation-error-fast.png", "tracking-error.png", "tracking-psd.png",
              "position-error.png", "calibration.png"]
    simulated = os.path.join(work, "simulated")
    make_directory(simulated, ["original", "classical", "pgnn", "my-law"], ["classical", "pgnn"], 2, True, False)
    check(script, simulated,
          always + ["validation.png", "cogging.png", "cogging-error.png", "gain.png", "gain-error.png"],
          ["latency.png skipped: the in-process commissioning runs on a virtual clock"])
    live = os.path.join(work, "live")
    make_directory(live, ["original", "classical", "pgnn"], [], 3, False, True)
    check(script, live, always + ["latency.png"],
          ["validation.png skipped", "cogging and gain plots skipped",
           # p99 of 90 % at <= 25.1 us and 10 % at <= 1000 us is in the upper bin.
           "latency.png: 6800 cycles in the logged runs, wake-up latency p99 ≤ 1e+03 µs, compute time p99 ≤ 3.98 µs"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
