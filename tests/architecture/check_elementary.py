#!/usr/bin/python3
"""No C library function whose result depends on the CPU in the product code.

glibc chooses exp, log, sin, cos, tanh, atan2, pow and their relatives at run
time by the CPU's features, and the variants differ in the last bits; the
identification turns on such bits (docs/commutation.md, "Reproducibility").
Product code (config/ commutation/ drivers/ daemon/ tools/) calls
clm::elementary:: instead. A finding is a call of std::F( or ::F( for such an
F, or Eigen's array form .F(), outside the files of EXEMPT (each with its
reason); each is printed as
"file:line: calls F (use clm::elementary:: ...)".

    check_elementary.py --source DIR      exit 0 clean, 1 with findings, 2 usage
    check_elementary.py --self-test       plants a call in a temporary tree: exit 0 when it is found
"""

import argparse
import os
import re
import sys
import tempfile

SCANNED = ["config", "commutation", "drivers", "daemon", "tools"]
SUFFIXES = (".hpp", ".cpp", ".h", ".cc")
# file: why it may call the C library's functions.
EXEMPT = {
    os.path.join("commutation", "elementary.cpp"): "its fallback beyond |x| >= 1.6e6 rad",
    os.path.join("daemon", "servo", "timing.cpp"): "histograms of measured wall-clock latencies, reproduced by no run",
}
DISPATCHED = ("exp|expm1|exp2|exp10|log|log1p|log2|log10|pow|sin|cos|tan|sincos|asin|acos|atan|atan2|"
              "sinh|cosh|tanh|asinh|acosh|atanh")
CALL = re.compile(r"(?<![A-Za-z0-9_])(?:std)?::(%s)\s*\(" % DISPATCHED)
ARRAY_CALL = re.compile(r"\.(%s)\(\)" % DISPATCHED)


def findings(source):
    found = []
    for folder in SCANNED:
        for root, _, files in os.walk(os.path.join(source, folder)):
            for name in sorted(files):
                if not name.endswith(SUFFIXES):
                    continue
                path = os.path.join(root, name)
                relative = os.path.relpath(path, source)
                if relative in EXEMPT:
                    continue
                with open(path, encoding="utf-8", errors="replace") as f:
                    for number, line in enumerate(f, 1):
                        code = line.split("//", 1)[0]
                        for match in list(CALL.finditer(code)) + list(ARRAY_CALL.finditer(code)):
                            found.append(f"{relative}:{number}: calls {match.group(1)} "
                                         f"(use clm::elementary::, commutation/elementary.hpp)")
    return found


def self_test():
    with tempfile.TemporaryDirectory() as tree:
        os.makedirs(os.path.join(tree, "drivers", "sim"))
        with open(os.path.join(tree, "drivers", "sim", "planted.cpp"), "w") as f:
            f.write("double f(double x) { return std::cos(x) + x.array().exp(); }  // std::sin( in a comment\n")
        got = findings(tree)
        expected = ["drivers/sim/planted.cpp:1: calls cos", "drivers/sim/planted.cpp:1: calls exp"]
        ok = len(got) == 2 and all(any(g.startswith(e) for g in got) for e in expected)
        print("self-test:", "planted calls found" if ok else f"expected {expected}, got {got}")
        return 0 if ok else 1


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--source", help="the source tree")
    group.add_argument("--self-test", action="store_true", help="check that a planted call is found")
    args = parser.parse_args()
    if args.self_test:
        return self_test()
    if not os.path.isdir(args.source):
        print(f"check_elementary.py: --source {args.source}: not a directory", file=sys.stderr)
        return 2
    found = findings(args.source)
    for line in found:
        print(line)
    print(f"{len(found)} calls of CPU-dependent C library functions in product code")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
