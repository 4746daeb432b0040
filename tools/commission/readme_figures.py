#!/usr/bin/python3
"""The README's commissioning figures, made from and checked against a run.

The README's table "What the main job gives" is the summary `clm commission`
prints on the embedded default (`bash .ci/main`, or `clm commission --config
config/servod.yaml --out DIR`). This script writes that table from a run's
report.json, with the date, the commit and the machine, and checks a fresh
run against the table the README holds.

    readme_figures.py print --report DIR/report.json
        prints the README's block (the table, the recommended law, the line
        saying when, on which commit and machine, with which command)
    readme_figures.py check --readme README.md --report DIR/report.json [--tolerance 0.10]
        every figure of the README's table within the tolerance (relative) of
        the run's (figures of rounding size, COLUMNS, count as zero), and the
        same law recommended; prints each figure compared,
        exits 1 naming every one outside, 2 on bad input

Standard library only.
"""

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import textwrap

HEADER = ("commutation         MSE y [N^2]  MSE x [N^2]  MSE z [N^2m^2]  true y [N^2]  static y [N^2]  tracking [m^2]  "
          "/oracle")
# Each column with the size below which a figure is rounding, zero for the
# check (the oracle's static error, the exact inverse's, is about 1e-27 N²).
COLUMNS = [("MSE y", 1e-12), ("MSE x", 1e-12), ("MSE z", 1e-12), ("true y", 1e-12), ("static y", 1e-12),
           ("tracking", 1e-24), ("/oracle", 0.0)]
BEGIN = "<!-- commissioning figures: made by tools/commission/readme_figures.py print -->"
END = "<!-- end of commissioning figures -->"


class BadInput(Exception):
    pass


def cell(value):
    """As clm commission prints a figure: three significant digits."""
    return f"{value:.3g}"


def run_figures(report):
    """{law: [the COLUMNS' figures]} and the recommended law, from a report.json."""
    try:
        results = report["commutations"]
        over_oracle = report["ratios"]["tracking_mse_over_oracle"]
        figures = {}
        for law, r in results.items():
            if not r.get("evaluated"):
                continue
            filtered = r["commutation_mse"]["filtered"]
            truth = [r[key]["filtered"][0] if key in r else None
                     for key in ("true_electromagnetic_mse", "static_electromagnetic_mse")]
            figures[law] = [filtered[0], filtered[1], filtered[2], *truth, r["tracking_mse_m2"], over_oracle.get(law)]
        return figures, report["recommended"]["law"]
    except (KeyError, IndexError, TypeError) as e:
        raise BadInput(f"report.json lacks {e}")


def readme_figures(text):
    """{law: [the COLUMNS' figures]} and the recommended law, from the README's table."""
    lines = text.splitlines()
    try:
        start = next(i for i, line in enumerate(lines) if line.strip() == HEADER)
    except StopIteration:
        raise BadInput("the README has no commissioning table (its header line: '" + HEADER + "')")
    figures, recommended = {}, None
    for line in lines[start + 1:]:
        words = line.split()
        if not words:
            break
        if line.strip().startswith("recommended for service:"):
            recommended = words[3].rstrip(";")
            break
        if len(words) != 1 + len(COLUMNS):
            raise BadInput(f"README table row '{line.strip()}': expected a law and {len(COLUMNS)} figures")
        try:
            figures[words[0]] = [None if w == "-" else float(w) for w in words[1:]]
        except ValueError:
            raise BadInput(f"README table row '{line.strip()}': a figure is not a number")
    if recommended is None:
        raise BadInput("the README's table has no 'recommended for service:' line")
    return figures, recommended


def git_commit(directory):
    try:
        return subprocess.run(["git", "-C", directory, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def print_block(report_path, repository):
    with open(report_path) as f:
        report = json.load(f)
    figures, recommended = run_figures(report)
    wall = report.get("total_wall_time_s")
    print(BEGIN)
    said = (f"On the embedded default ({datetime.date.today().isoformat()}, commit {git_commit(repository)}, "
            f"{cpu_model()}, {os.cpu_count()} CPUs"
            + (f"; commissioning took {wall:.0f} s wall in this run" if wall else "")
            + "; `bash .ci/main`, whose last step is `build/bin/clm commission --config config/servod.yaml "
            "--out out/commission`; the same figures on every x86-64 machine, docs/commutation.md, "
            "\"Reproducibility\"):")
    print(textwrap.fill(said, width=76, break_long_words=False, break_on_hyphens=False))
    print()
    print("    " + HEADER)
    for law, values in figures.items():
        cells = ["-" if v is None else cell(v) for v in values]
        widths = [len(name) for name in HEADER.split("  ")[1:] if name]
        print("    " + f"{law:<18}" + "".join(f"{c:>{w + 2}}" for c, w in zip(cells, widths)))
    print(f"    recommended for service: {recommended}")
    print()
    print(END)


def check(readme_path, report_path, tolerance):
    with open(readme_path) as f:
        expected, expected_law = readme_figures(f.read())
    with open(report_path) as f:
        measured, measured_law = run_figures(json.load(f))
    failures = []
    for law, values in expected.items():
        if law not in measured:
            failures.append(f"{law}: in the README, not evaluated by the run")
            continue
        for (column, rounding), want, got in zip(COLUMNS, values, measured[law]):
            if want is None or got is None:
                if (want is None) != (got is None):
                    failures.append(f"{law} {column}: README {want}, run {got}")
                continue
            # The README holds three significant digits: their rounding is inside the tolerance too.
            if max(abs(want), abs(got)) < rounding:
                deviation = 0.0
            else:
                deviation = abs(got - want) / abs(want) if want != 0 else abs(got)
            ok = deviation <= tolerance
            print(f"{'ok:  ' if ok else 'FAIL:'} {law:<16} {column:<9} README {cell(want):>9}  run {cell(got):>9}  "
                  f"{100 * deviation:5.1f} % (bound {100 * tolerance:.0f} %)")
            if not ok:
                failures.append(f"{law} {column}: README {cell(want)}, run {cell(got)} ({100 * deviation:.1f} %, "
                                f"bound {100 * tolerance:.0f} %)")
    for law in measured:
        if law not in expected:
            failures.append(f"{law}: evaluated by the run, missing from the README")
    ok = expected_law == measured_law
    print(f"{'ok:  ' if ok else 'FAIL:'} recommended law: README {expected_law}, run {measured_law}")
    if not ok:
        failures.append(f"recommended law: README {expected_law}, run {measured_law}")
    for failure in failures:
        print(f"readme_figures.py: the README's figures do not match the run: {failure}", file=sys.stderr)
    return 1 if failures else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="what", required=True)
    p = sub.add_parser("print", help="the README's block from a report.json")
    p.add_argument("--report", required=True)
    p.add_argument("--repository", default=os.path.dirname(os.path.abspath(__file__)))
    c = sub.add_parser("check", help="a report.json against the README's table")
    c.add_argument("--readme", required=True)
    c.add_argument("--report", required=True)
    c.add_argument("--tolerance", type=float, default=0.10)
    args = parser.parse_args()
    try:
        if args.what == "print":
            print_block(args.report, args.repository)
            return 0
        if not 0 < args.tolerance < 1:
            raise BadInput(f"--tolerance {args.tolerance}: must be in (0, 1)")
        return check(args.readme, args.report, args.tolerance)
    except (OSError, json.JSONDecodeError, BadInput) as e:
        print(f"readme_figures.py: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
