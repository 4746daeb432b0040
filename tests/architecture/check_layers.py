#!/usr/bin/python3
"""The layer rule of the source tree, checked.

Each layer uses only the layers below it:

    config, lcmtypes (0) <- commutation (1) <- drivers (2) <- daemon (3) <- tools (4)

1. Every `#include "..."` in config/ commutation/ drivers/ daemon/ tools/ is
   placed in a layer: by its first path component (config/, commutation/,
   drivers/, daemon/, tools/, lcmtypes/), as a generated LCM header
   (clm_lcm/...) or a header of the build's generated/ directory (rank 0), or,
   failing those, relative to the including file. An include from a higher
   layer than the including file's, or one that cannot be placed, is a
   finding: "file:line: includes "path" (layer a, rank r) from layer b (rank s)".
   Tests, benchmarks and fuzz harnesses (tests/) may include anything and are
   not scanned.
2. With --build, the daemon's link line
   (BUILD/daemon/servod/CMakeFiles/clm-servod.dir/link.txt) and, when the
   binary exists, `ldd BUILD/bin/clm-servod` must name neither Ceres nor the
   tools-only libraries clm::identification and clm::tool_data.

Exit status 0 without findings, 1 with findings (each printed on one line),
2 on a usage error. Runs as the CTest `architecture_layers` (label unit);
test_check_layers.py checks that it can fail.
"""

import argparse
import os
import re
import subprocess
import sys

RANKS = {"config": 0, "lcmtypes": 0, "commutation": 1, "drivers": 2, "daemon": 3, "tools": 4}
SCANNED = ["config", "commutation", "drivers", "daemon", "tools"]
SOURCE_SUFFIXES = (".hpp", ".cpp", ".h", ".cc", ".hh", ".ipp", ".inl")
INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"')
# What the daemon must not link: (pattern on the link line / ldd output, what it is).
FORBIDDEN_LINKS = [
    (re.compile(r"ceres", re.IGNORECASE), "Ceres"),
    (re.compile(r"clm_identification"), "clm::identification"),
    (re.compile(r"clm_tool_data"), "clm::tool_data (tools/data)"),
]


def layer_of_path(relative_path):
    """Layer name of a path relative to the source root, or None."""
    first = relative_path.replace(os.sep, "/").split("/", 1)[0]
    return first if first in RANKS else None


def place_include(source_root, generated_dir, including_file, included):
    """(layer, rank) of an included path, or None when it cannot be placed."""
    layer = layer_of_path(included)
    if layer is not None:
        return layer, RANKS[layer]
    if included.startswith("clm_lcm/"):
        return "lcmtypes (generated)", 0
    if generated_dir and os.path.isfile(os.path.join(generated_dir, included)):
        return "generated", 0
    beside = os.path.normpath(os.path.join(os.path.dirname(including_file), included))
    if os.path.isfile(beside):
        relative = os.path.relpath(beside, source_root)
        layer = layer_of_path(relative)
        if layer is not None and not relative.startswith(".."):
            return layer, RANKS[layer]
    return None


def include_findings(source_root, generated_dir):
    findings = []
    for top in SCANNED:
        top_dir = os.path.join(source_root, top)
        if not os.path.isdir(top_dir):
            continue
        own_rank = RANKS[top]
        for directory, subdirectories, files in os.walk(top_dir):
            subdirectories.sort()
            for name in sorted(files):
                if not name.endswith(SOURCE_SUFFIXES):
                    continue
                path = os.path.join(directory, name)
                shown = os.path.relpath(path, source_root)
                with open(path, encoding="utf-8", errors="replace") as f:
                    for number, line in enumerate(f, start=1):
                        match = INCLUDE.match(line)
                        if not match:
                            continue
                        included = match.group(1)
                        placed = place_include(source_root, generated_dir, path, included)
                        if placed is None:
                            findings.append(f'{shown}:{number}: includes "{included}", which is in no known layer '
                                            f"(file of layer {top}, rank {own_rank})")
                        elif placed[1] > own_rank:
                            findings.append(f'{shown}:{number}: includes "{included}" (layer {placed[0]}, rank '
                                            f"{placed[1]}) from layer {top} (rank {own_rank})")
    return findings


def link_findings(build_dir):
    findings = []
    link_txt = os.path.join(build_dir, "daemon", "servod", "CMakeFiles", "clm-servod.dir", "link.txt")
    if not os.path.isfile(link_txt):
        return [f"{link_txt}: missing (is {build_dir} a configured build directory?)"]
    with open(link_txt, encoding="utf-8", errors="replace") as f:
        link_line = f.read()
    for pattern, what in FORBIDDEN_LINKS:
        for token in link_line.split():
            if pattern.search(token):
                findings.append(f"{link_txt}: clm-servod links {what}: {token}")
    binary = os.path.join(build_dir, "bin", "clm-servod")
    if os.path.isfile(binary):
        try:
            ldd = subprocess.run(["ldd", binary], capture_output=True, text=True, check=False).stdout
        except OSError:
            ldd = ""
        for pattern, what in FORBIDDEN_LINKS:
            for line in ldd.splitlines():
                if pattern.search(line):
                    findings.append(f"ldd {binary}: clm-servod loads {what}: {line.strip()}")
    return findings


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--source", required=True, help="source tree root")
    parser.add_argument("--build", help="build directory: check clm-servod's link line and its generated/ headers")
    args = parser.parse_args(argv)
    source_root = os.path.abspath(args.source)
    if not os.path.isdir(source_root):
        print(f"{args.source}: not a directory", file=sys.stderr)
        return 2
    build_dir = os.path.abspath(args.build) if args.build else None
    generated_dir = os.path.join(build_dir, "generated") if build_dir else None
    findings = include_findings(source_root, generated_dir)
    if build_dir:
        findings += link_findings(build_dir)
    for finding in findings:
        print(finding)
    if findings:
        print(f"check_layers: {len(findings)} finding(s)", file=sys.stderr)
        return 1
    print("check_layers: every include is from the same or a lower layer; clm-servod links no tools-only library")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
