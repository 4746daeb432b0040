#!/usr/bin/env python3
"""Tiles the data rows of an experiment CSV (clm commission's experiments.csv)
to N rows, each further copy's t_s shifted by 200 s, for measuring how the
tools scale with the data (docs/benchmarks.md, "Memory of clm identify").

    tests/bench/tile_experiments.py experiments.csv 1000000 exp-1000000.csv
"""
import sys


def main() -> None:
    if len(sys.argv) != 4:
        sys.exit("usage: tile_experiments.py INPUT.csv ROWS OUTPUT.csv")
    source, rows_wanted, output = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    with open(source) as f:
        header = f.readline()
        rows = [line.rstrip("\n").split(",", 1) for line in f if line.strip()]
    if not header.startswith("t_s,"):
        sys.exit(source + ": the first column must be t_s")
    with open(output, "w") as f:
        f.write(header)
        for k in range(rows_wanted):
            copy, r = divmod(k, len(rows))
            t, rest = rows[r]
            f.write(repr(float(t) + 200.0 * copy) + "," + rest + "\n")


if __name__ == "__main__":
    main()
