#!/usr/bin/python3
"""CTest (label slow): identification gives the same result on any x86-64 CPU.

Commissions the default motor twice, once as this machine runs it and once
with glibc's AVX2, FMA and AVX paths switched off (GLIBC_TUNABLES), which
is what a CPU without them runs; then identifies the first run's experiment
data with `clm identify --threads 1` and `--threads 2`. Requires, as
docs/commutation.md ("Reproducibility") promises:

  * the same recommended law and the same capacity chosen for the PGNN and
    the spline;
  * every figure of report.json (results, ratios, calibration,
    identification, selection) within 10 % of the other run's;
  * with --readme, the README's commissioning table (the main job's
    summary) within 10 % of the native run, the same law recommended
    (tools/commission/readme_figures.py check);
  * the commutation of every law (the PGNN, its paper-size sibling, the
    spline, the spline from positions, calibrated classical), evaluated by
    `clm commutate` on a grid of requests over the stroke, within 1 % of the
    largest magnitude, compared as m·cos δ, m·sin δ per coil set.

It prints the largest differences it measured (zero when the runs give the
same bits, which is what the code is built to do).

    reproducibility_test.py --clm build/bin/clm --config config/servod.yaml \\
        --motor config/motor-sim.yaml --work DIR
"""

import argparse
import csv
import json
import math
import os
import shutil
import subprocess
import sys

RESTRICTED = "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX,-AVX512F"
REPORT_SECTIONS = ["results", "ratios", "calibration", "identification", "selection"]
FIGURE_TOLERANCE = 0.10      # relative, every figure of report.json
COMMUTATION_TOLERANCE = 0.01  # of the largest magnitude
LAWS = [("model-pgnn.yaml", "--model"), ("model-pgnn-paper.yaml", "--model"), ("model-spline.yaml", "--model"),
        ("model-spline-position.yaml", "--model"), ("calibration.yaml", "--calibration")]

failures = []


def check(condition, message):
    print(("ok:   " if condition else "FAIL: ") + message)
    if not condition:
        failures.append(message)


def run(command, env=None, log=None):
    result = subprocess.run(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if log:
        with open(log, "w") as f:
            f.write(result.stdout)
    if result.returncode != 0:
        print(result.stdout[-3000:])
        sys.exit(f"FAIL: {' '.join(command)} exited {result.returncode}")
    return result.stdout


def leaves(value, path=""):
    """Every number and string of a JSON value, by its path."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield from leaves(item, f"{path}.{key}" if path else key)
    elif isinstance(value, list):
        for k, item in enumerate(value):
            yield from leaves(item, f"{path}[{k}]")
    else:
        yield path, value


def compare_reports(a, b, what):
    with open(a) as f:
        first = json.load(f)
    with open(b) as f:
        second = json.load(f)
    check(first["recommended"]["law"] == second["recommended"]["law"],
          f"{what}: recommended law {first['recommended']['law']} and {second['recommended']['law']}")
    check(first["recommended"]["force_sensor_law"] == second["recommended"]["force_sensor_law"],
          f"{what}: force-sensor law {first['recommended']['force_sensor_law']} and "
          f"{second['recommended']['force_sensor_law']}")
    for kind in ("pgnn", "spline"):
        chosen = [[t["capacity"] for t in r["selection"][kind]["trials"] if t["chosen"]] for r in (first, second)]
        check(chosen[0] == chosen[1], f"{what}: {kind} capacity chosen {chosen[0]} and {chosen[1]}")
    other = dict(leaves({k: second.get(k) for k in REPORT_SECTIONS}))
    worst, worst_path, compared = 0.0, "", 0
    for path, value in leaves({k: first.get(k) for k in REPORT_SECTIONS}):
        if path not in other:
            check(False, f"{what}: {path} is in one report only")
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            if value != other[path]:
                check(False, f"{what}: {path} is {value!r} and {other[path]!r}")
            continue
        compared += 1
        scale = max(abs(value), abs(other[path]))
        difference = 0.0 if scale == 0.0 else abs(value - other[path]) / scale
        if difference > worst:
            worst, worst_path = difference, path
    check(worst <= FIGURE_TOLERANCE,
          f"{what}: {compared} figures of report.json, largest relative difference {worst:.3g} "
          f"({worst_path or 'none'}) <= {FIGURE_TOLERANCE}")


def write_requests(path):
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(["y_m", "Fy_N", "Fx_N", "Tz_Nm"])
        for k in range(201):
            y = -0.1 + 0.001 * k
            for fy in (-150.0, -40.0, 40.0, 150.0):
                out.writerow([repr(y), repr(fy), repr(10.0 * math.sin(90.0 * y)), repr(0.5 * math.cos(70.0 * y))])


def setpoints(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    sets = sorted({int(name.rsplit("_", 1)[1]) for name in rows[0] if name.startswith("magnitude_N_")})
    vectors = []
    for row in rows:
        for l in sets:
            m, d = float(row[f"magnitude_N_{l}"]), float(row[f"delta_rad_{l}"])
            vectors.append((m * math.cos(d), m * math.sin(d), abs(m)))
    return vectors


def compare_laws(clm, motor, requests, first_dir, second_dir, work, what, laws):
    for name, flag in laws:
        first, second = os.path.join(first_dir, name), os.path.join(second_dir, name)
        if not os.path.exists(first) and not os.path.exists(second):
            continue
        if not (os.path.exists(first) and os.path.exists(second)):
            check(False, f"{what}: {name} written by one run only")
            continue
        outputs = []
        for k, law in enumerate((first, second)):
            output = os.path.join(work, f"setpoints-{what.replace(' ', '-')}-{k}-{name}.csv")
            run([clm, "commutate", "--motor", motor, flag, law, "--input", requests, "--output", output])
            outputs.append(setpoints(output))
        largest = max(v[2] for v in outputs[0] + outputs[1])
        difference = max(math.hypot(a[0] - b[0], a[1] - b[1]) for a, b in zip(outputs[0], outputs[1]))
        same_bits = open(first, "rb").read().split(b"created_utc")[0] == open(second, "rb").read().split(b"created_utc")[0]
        check(difference <= COMMUTATION_TOLERANCE * largest,
              f"{what}: {name}: largest commutation difference {difference:.3g} N = "
              f"{difference / largest:.3g} of the largest magnitude {largest:.4g} N <= {COMMUTATION_TOLERANCE}"
              f"{' (files equal up to their time stamp)' if same_bits else ''}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clm", required=True)
    parser.add_argument("--config", required=True)
    parser.add_argument("--motor", required=True)
    parser.add_argument("--work", required=True)
    parser.add_argument("--readme", help="also check the README's commissioning table against the native run "
                                         "(tools/commission/readme_figures.py check)")
    args = parser.parse_args()
    shutil.rmtree(args.work, ignore_errors=True)
    os.makedirs(args.work)
    native, restricted = os.path.join(args.work, "native"), os.path.join(args.work, "restricted")
    env = dict(os.environ)
    env.pop("GLIBC_TUNABLES", None)
    run([args.clm, "commission", "--config", args.config, "--out", native, "--no-plots"], env,
        os.path.join(args.work, "native.log"))
    run([args.clm, "commission", "--config", args.config, "--out", restricted, "--no-plots"],
        dict(env, GLIBC_TUNABLES=RESTRICTED), os.path.join(args.work, "restricted.log"))
    if args.readme:
        figures = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "commission",
                               "readme_figures.py")
        result = subprocess.run([sys.executable, figures, "check", "--readme", args.readme, "--report",
                                 os.path.join(native, "report.json")], capture_output=True, text=True)
        print(result.stdout, end="")
        check(result.returncode == 0, "the README's commissioning table within 10 % of this run: " +
              (result.stderr.strip().replace("\n", "; ") or "every figure"))
    requests = os.path.join(args.work, "requests.csv")
    write_requests(requests)
    compare_reports(os.path.join(native, "report.json"), os.path.join(restricted, "report.json"),
                    "commissioning with glibc's AVX2/FMA paths and without")
    compare_laws(args.clm, args.motor, requests, native, restricted, args.work, "AVX2-FMA and baseline", LAWS)

    threads = []
    for count in (1, 2):
        directory = os.path.join(args.work, f"threads-{count}")
        os.makedirs(directory)
        log = run([args.clm, "identify", "--motor", args.motor, "--data", os.path.join(native, "experiments.csv"),
                   "--output", os.path.join(directory, "model-pgnn.yaml"), "--threads", str(count)], env,
                  os.path.join(directory, "identify.log"))
        threads.append([line for line in log.splitlines() if "chosen" in line or "capacity" in line])
    check(threads[0] == threads[1], f"clm identify with 1 and 2 threads: capacity lines {threads[0]} and {threads[1]}")
    compare_laws(args.clm, args.motor, requests, os.path.join(args.work, "threads-1"),
                 os.path.join(args.work, "threads-2"), args.work, "threads 1 and 2", [("model-pgnn.yaml", "--model")])

    if failures:
        print(f"{len(failures)} checks failed:")
        for message in failures:
            print("  " + message)
        return 1
    print("every check passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
