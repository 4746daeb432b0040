#!/usr/bin/python3
"""Benchmark: our PGNN identification against the PyTorch reference.

Both sides identify the paper's PGNN (2/16 tanh neurons, Λ = 0.1, no field
harmonics, no nuisance terms) from the same experiments. Per run (default 3
runs, one after the other):
  1. `clm commission --out OUT/run-k --no-plots --no-nuisance --no-selection`:
     the simulated experiments (OUT/run-k/experiments.csv), our identification
     (wall time report.json step_wall_time_s["identify pgnn"]) and our model
     OUT/run-k/model-pgnn.yaml;
  2. compare_models --no-closed-loop on our model: its cost (26) per coil set
     on the training blocks, the quantity the reference minimises (ours' model
     is polished on all samples at the end, docs/commutation.md
     "Identification" step 5, so report.json's cost is over all samples);
  3. tools/reference/pgnn_torch.py on the same experiments.csv, with those
     costs as targets (the report says when L-BFGS first reached them):
     OUT/run-k/model-torch.yaml, OUT/run-k/torch.json;
  4. compare_models (tests/bench/compare_models.cpp) on both model files: cost
     (26) of both by one C++ code path, the closed-loop evaluation of
     `clm commission` for both on fresh daemons (commutation and tracking
     MSE), and our identification timed again in total (wall and process CPU
     time, `--time-ours --no-nuisance --no-selection`): OUT/run-k/compare.json.
The ratio torch/ours is taken within each run; the summary gives every run
and the medians (OUT/summary.json, OUT/summary.md).

    /usr/bin/python3 tools/reference/compare_identification.py --build build --out /tmp/clm-vs-torch
"""

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(os.path.dirname(HERE))


def run(command, log_path):
    print("$ " + " ".join(command), flush=True)
    start = time.perf_counter()
    with open(log_path, "w") as log:
        completed = subprocess.run(command, stdout=log, stderr=subprocess.STDOUT)
    if completed.returncode != 0:
        sys.exit(f"failed ({completed.returncode}): {' '.join(command)}; see {log_path}")
    return time.perf_counter() - start


def machine():
    model = "unknown"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    return {"nproc": os.cpu_count(), "cpu_model": model, "kernel": platform.release(),
            "python": platform.python_version()}


def write_atomically(path, text):
    temporary = path + ".tmp"
    with open(temporary, "w") as f:
        f.write(text)
    os.replace(temporary, path)


def load_json(path):
    with open(path) as f:
        return json.load(f)


def one_run(args, k):
    out = os.path.join(args.out, f"run-{k}")
    os.makedirs(out, exist_ok=True)
    clm = os.path.join(args.build, "bin", "clm")
    compare = os.path.join(args.build, "bin", "compare_models")
    csv = os.path.join(out, "experiments.csv")
    ours_model = os.path.join(out, "model-pgnn.yaml")
    torch_model = os.path.join(out, "model-torch.yaml")
    paper = ["--no-nuisance", "--no-selection"]
    load_before = os.getloadavg()
    run([clm, "commission", "--config", args.config, "--out", out, "--no-plots"] + paper,
        os.path.join(out, "commission.log"))
    report = load_json(os.path.join(out, "report.json"))
    ours_costs_all = [c["regularised_cost"] for c in report["identification"]["pgnn"]]
    ours_json = os.path.join(out, "compare-ours.json")
    run([compare, "--config", args.config, "--data", csv, "--model", "ours=" + ours_model, "--no-closed-loop",
         "--json", ours_json], os.path.join(out, "compare-ours.log"))
    targets = [c["cost26"] for c in load_json(ours_json)["models"]["ours"]["coil_sets"]]
    torch_command = ["/usr/bin/python3", os.path.join(HERE, "pgnn_torch.py"), "--data", csv,
                     "--motor", args.config, "--out", torch_model,
                     "--report", os.path.join(out, "torch.json"), "--threads", str(args.threads),
                     "--target-costs", ",".join(repr(c) for c in targets)] + args.torch_args
    run(torch_command, os.path.join(out, "torch.log"))
    torch_report = load_json(os.path.join(out, "torch.json"))
    run([compare, "--config", args.config, "--data", csv, "--model", "ours=" + ours_model,
         "--model", "torch=" + torch_model, "--json", os.path.join(out, "compare.json"), "--time-ours"] + paper,
        os.path.join(out, "compare.log"))
    comparison = load_json(os.path.join(out, "compare.json"))
    load_after = os.getloadavg()

    ours_step_s = report["step_wall_time_s"]["identify pgnn"]
    torch_total_s = torch_report["identify_wall_time_s"]
    result = {
        "run": k,
        "load_average_before": load_before,
        "load_average_after": load_after,
        "ours": {
            "identify_wall_s": ours_step_s,  # report.json, whole step incl. writing the model
            "timed_again": comparison["ours_timing"],  # compare_models --time-ours
            "cost26_all_samples": ours_costs_all,  # report.json: the model put to use, on every sample
            "cost26_compare_models": [c["cost26"] for c in comparison["models"]["ours"]["coil_sets"]],
            "program": comparison["models"]["ours"]["program"],
            "validation": comparison["models"]["ours"].get("validation"),
        },
        "torch": {
            "identify_wall_s": torch_total_s,
            "identify_cpu_s": torch_report["identify_cpu_time_s"],
            "coil_sets": [{key: c[key] for key in ("wall_time_s", "cpu_time_s", "regularised_cost", "cost_before_eq31",
                                                    "iterations", "function_evaluations", "best_restart",
                                                    "target_cost", "target_reached", "proposition_4_1_holds")}
                          for c in torch_report["coil_sets"]],
            "cost26_compare_models": [c["cost26"] for c in comparison["models"]["torch"]["coil_sets"]],
            "program": comparison["models"]["torch"]["program"],
            "validation": comparison["models"]["torch"].get("validation"),
            "options": torch_report["options"],
            "version": torch_report["torch_version"],
        },
    }
    result["ratio_wall"] = torch_total_s / ours_step_s
    result["ratio_cpu"] = torch_report["identify_cpu_time_s"] / comparison["ours_timing"]["total_cpu_s"]
    print(f"run {k}: ours {ours_step_s:.1f} s (report.json), torch {torch_total_s:.1f} s: ratio {result['ratio_wall']:.1f}x "
          f"wall, {result['ratio_cpu']:.1f}x CPU; cost (26) on the training blocks ours {targets}, torch "
          f"{result['torch']['cost26_compare_models']}; load {load_before[0]:.1f} -> {load_after[0]:.1f}",
          flush=True)
    return result


def med(values):
    return statistics.median(values)


def summary_markdown(summary):
    runs = summary["runs"]
    n = len(runs)
    coil_sets = len(runs[0]["ours"]["cost26_compare_models"])
    g = lambda v: f"{v:.4g}"
    lines = [f"Medians of {n} runs (each run: ours, then torch, then the evaluation; per-run values in summary.json). "
             "Cost (26) on the training blocks, both models by compare_models.", "",
             "| coil set | ours cost (26) | torch cost (26) | torch wall [s] | torch CPU [s] "
             "| torch reached ours' cost after [s wall] |",
             "|---|---|---|---|---|---|"]
    for l in range(coil_sets):
        ours_cost = med([r["ours"]["cost26_compare_models"][l] for r in runs])
        torch_cost = med([r["torch"]["cost26_compare_models"][l] for r in runs])
        torch_wall = med([r["torch"]["coil_sets"][l]["wall_time_s"] for r in runs])
        torch_cpu = med([r["torch"]["coil_sets"][l]["cpu_time_s"] for r in runs])
        reached = [r["torch"]["coil_sets"][l]["target_reached"] for r in runs]
        reached_text = ("not within the budget (all runs)" if all(x is None for x in reached) else
                        ", ".join("–" if x is None else f"{x['wall_s']:.1f}" for x in reached))
        lines.append(f"| {l + 1} | {ours_cost:.5f} | {torch_cost:.5f} | {torch_wall:.1f} | {torch_cpu:.1f} "
                     f"| {reached_text} |")
    lines += ["", "| | ours wall [s] (report.json) | ours CPU [s] (timed again) | ours wall [s] (timed again) "
                  "| torch wall [s] | torch CPU [s] |",
              "|---|---|---|---|---|---|",
              f"| all coil sets | {med([r['ours']['identify_wall_s'] for r in runs]):.1f} "
              f"| {med([r['ours']['timed_again']['total_cpu_s'] for r in runs]):.1f} "
              f"| {med([r['ours']['timed_again']['total_s'] for r in runs]):.1f} "
              f"| {med([r['torch']['identify_wall_s'] for r in runs]):.1f} "
              f"| {med([r['torch']['identify_cpu_s'] for r in runs]):.1f} |"]
    wall_ratios = ", ".join("%.1f" % r["ratio_wall"] for r in runs)
    cpu_ratios = ", ".join("%.1f" % r["ratio_cpu"] for r in runs)
    lines += ["", f"Ratio torch/ours within each run: wall {wall_ratios} "
                  f"(median {med([r['ratio_wall'] for r in runs]):.1f}x); CPU {cpu_ratios} "
                  f"(median {med([r['ratio_cpu'] for r in runs]):.1f}x).", "",
              "| model | program: commutation MSE filtered y [N²] | x [N²] | z [N²m²] | unfiltered y / x / z | tracking MSE [m²] "
              "| validation: filtered y / x / z | tracking [m²] |",
              "|---|---|---|---|---|---|---|---|"]
    for who in ("ours", "torch"):
        p = lambda key, i=None: med([r[who]["program"][key][i] if i is not None else r[who]["program"][key] for r in runs])
        v = lambda key, i=None: med([r[who]["validation"][key][i] if i is not None else r[who]["validation"][key] for r in runs])
        lines.append(f"| {who} | {g(p('mse_filtered', 0))} | {g(p('mse_filtered', 1))} | {g(p('mse_filtered', 2))} "
                     f"| {g(p('mse_unfiltered', 0))} / {g(p('mse_unfiltered', 1))} / {g(p('mse_unfiltered', 2))} "
                     f"| {g(p('tracking_mse_m2'))} | {g(v('mse_filtered', 0))} / {g(v('mse_filtered', 1))} / "
                     f"{g(v('mse_filtered', 2))} | {g(v('tracking_mse_m2'))} |")
    loads = [r["load_average_before"][0] for r in runs] + [r["load_average_after"][0] for r in runs]
    lines += ["", f"1-minute load average during the runs: {min(loads):.1f} to {max(loads):.1f} on "
                  f"{summary['machine']['nproc']} CPUs."]
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", default=os.path.join(SOURCE, "build"), help="build directory with bin/clm and bin/compare_models")
    parser.add_argument("--config", default=os.path.join(SOURCE, "config", "servod.yaml"))
    parser.add_argument("--out", required=True)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--threads", type=int, default=2, help="torch threads (ours uses 2)")
    parser.add_argument("torch_args", nargs="*", help="after --: further pgnn_torch.py options")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    summary = {"machine": machine(), "command": sys.argv, "runs": []}
    for k in range(1, args.runs + 1):
        summary["runs"].append(one_run(args, k))
        write_atomically(os.path.join(args.out, "summary.json"), json.dumps(summary, indent=2) + "\n")
    text = summary_markdown(summary)
    write_atomically(os.path.join(args.out, "summary.md"), text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
