#!/usr/bin/env python3
"""One window of `clm scope` as a PNG: a strip per channel over the time from
the trigger, the trigger instant and level marked.

    plot_capture.py WINDOW.csv WINDOW.png [--trigger-channel NAME --level X --edge E]

WINDOW.csv is what clm scope exports: t_s, t_minus_trigger_s, then the
channels. The PNG is written to a temporary file and renamed.
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv")
    parser.add_argument("png")
    parser.add_argument("--trigger-channel")
    parser.add_argument("--level", type=float)
    parser.add_argument("--edge")
    args = parser.parse_args()
    with open(args.csv, newline="") as f:
        rows = list(csv.reader(f))
    names, data = rows[0], [[float(v) for v in row] for row in rows[1:]]
    if not data:
        sys.exit(f"{args.csv}: no rows")
    columns = {name: [row[k] for row in data] for k, name in enumerate(names)}
    channels = names[2:]
    t = columns["t_minus_trigger_s"]
    triggered = args.trigger_channel is not None
    fig, axes = plt.subplots(len(channels), 1, sharex=True, figsize=(9, 1.9 * len(channels) + 0.8), squeeze=False)
    for axis, name in zip(axes[:, 0], channels):
        axis.plot(t, columns[name], lw=1.0)
        axis.set_ylabel(name)
        axis.grid(True, alpha=0.3)
        if triggered:
            axis.axvline(0.0, color="k", lw=0.8, ls="--")
        if triggered and name == args.trigger_channel and args.level is not None:
            axis.axhline(args.level, color="r", lw=0.8, ls=":", label=f"trigger {args.edge} {args.level:g}")
            axis.legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("t - trigger [s]" if triggered else "t - latest [s]")
    fig.suptitle(f"clm scope: {os.path.basename(args.csv)}, {len(t)} states", fontsize=10)
    fig.tight_layout()
    temporary = args.png + ".tmp.png"
    fig.savefig(temporary, dpi=100)
    os.replace(temporary, args.png)


if __name__ == "__main__":
    main()
