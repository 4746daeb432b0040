#!/usr/bin/python3
"""check_layers.py can fail: it is run on small fixture trees (a clean one, then
one with an upward include, a relative upward include, an include in no layer,
and a daemon link line naming Ceres and clm::identification) and must pass the
clean tree and report exactly the planted findings, with file, line and path.
Exit status 0 when every expectation holds, 1 otherwise."""

import os
import subprocess
import sys
import tempfile

CHECKER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "check_layers.py")


def write(root, relative, text):
    path = os.path.join(root, relative)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def clean_tree(root):
    write(root, "config/yaml_reader.hpp", "#pragma once\n#include <string>\n")
    write(root, "commutation/model.hpp", '#pragma once\n#include "config/yaml_reader.hpp"\n')
    write(root, "drivers/can_bus.hpp", '#pragma once\n#include "commutation/model.hpp"\n')
    write(root, "daemon/servod/servod.cpp",
          '#include "drivers/can_bus.hpp"\n#include "clm_lcm/servo_state_t.hpp"\n#include "clm_version.hpp"\n'
          '#include "daemon/servod/servod.hpp"\n')
    write(root, "daemon/servod/servod.hpp", '#pragma once\n#include "commutation/model.hpp"\n')
    write(root, "tools/cli/main.cpp", '#include "daemon/servod/servod.hpp"\n#include "tools/cli/local.hpp"\n')
    write(root, "tools/cli/local.hpp", "#pragma once\n")
    # Tests may include anything.
    write(root, "tests/test_all.cpp", '#include "tools/cli/local.hpp"\n')


def build_dir(root, link_line):
    write(root, "generated/clm_version.hpp", "#pragma once\n")
    write(root, "daemon/servod/CMakeFiles/clm-servod.dir/link.txt", link_line + "\n")


def run(source, build):
    result = subprocess.run([sys.executable, CHECKER, "--source", source, "--build", build],
                            capture_output=True, text=True, check=False)
    return result.returncode, result.stdout


def main():
    failures = []

    def expect(condition, what, output):
        if not condition:
            failures.append(f"{what}\n--- checker output ---\n{output}")

    clean_link = "/usr/bin/c++ -O3 CMakeFiles/clm-servod.dir/main.cpp.o -o bin/clm-servod libclm_servod.a -lyaml-cpp"
    with tempfile.TemporaryDirectory() as work:
        source, build = os.path.join(work, "src"), os.path.join(work, "build")
        clean_tree(source)
        build_dir(build, clean_link)
        status, output = run(source, build)
        expect(status == 0, f"clean fixture: expected exit 0, got {status}", output)

        # Upward includes, one of each kind, at known lines.
        write(source, "commutation/bad.hpp",
              '#pragma once\n#include "config/yaml_reader.hpp"\n#include "daemon/servod/servod.hpp"\n')
        write(source, "drivers/relative.cpp", '#include "../tools/cli/local.hpp"\n')
        write(source, "config/unknown.cpp", "// nothing\n#include \"nowhere/thing.hpp\"\n")
        status, output = run(source, build)
        expect(status == 1, f"upward includes: expected exit 1, got {status}", output)
        expected = [
            'commutation/bad.hpp:3: includes "daemon/servod/servod.hpp" (layer daemon, rank 3) '
            "from layer commutation (rank 1)",
            'drivers/relative.cpp:1: includes "../tools/cli/local.hpp" (layer tools, rank 4) from layer drivers (rank 2)',
            'config/unknown.cpp:2: includes "nowhere/thing.hpp", which is in no known layer',
        ]
        for line in expected:
            expect(line in output, f"upward includes: missing finding: {line}", output)
        lines = [line for line in output.splitlines() if line.strip()]
        expect(len(lines) == len(expected), f"upward includes: expected {len(expected)} findings", output)

        # The daemon linking Ceres and clm::identification, includes clean again.
        for planted in ("commutation/bad.hpp", "drivers/relative.cpp", "config/unknown.cpp"):
            os.remove(os.path.join(source, planted))
        build_dir(build, clean_link + " ../commutation/libclm_identification.a /usr/lib/x86_64-linux-gnu/libceres.so.3")
        status, output = run(source, build)
        expect(status == 1, f"forbidden links: expected exit 1, got {status}", output)
        expect("clm-servod links Ceres" in output, "forbidden links: Ceres not reported", output)
        expect("clm-servod links clm::identification" in output, "forbidden links: identification not reported",
               output)

    for failure in failures:
        print("FAILED:", failure)
    if failures:
        return 1
    print("test_check_layers: the checker passes the clean fixture and reports every planted finding")
    return 0


if __name__ == "__main__":
    sys.exit(main())
