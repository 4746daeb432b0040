#!/usr/bin/env bash
# `clm identify --model pgnn` with its defaults (capacity selection and
# nuisance terms included) against the PyTorch reference training the paper's
# 2/16 PGNN (tools/reference/pgnn_torch.py, its defaults: L-BFGS, strong
# Wolfe, 5 restarts of 200 iterations, 5000 more on the best) and against
# the same training by an independent L-BFGS (SciPy's L-BFGS-B,
# `--optimiser scipy`), on the same experiments, one motor after the other;
# ours first, then the two references, in the same run. Wall and CPU time (user + system, every thread) of each
# process from GNU time; the ratio reference/ours of each. Prints a Markdown
# table and writes OUT/speed.md.
#
#   tools/reference/speed_vs_torch.sh BUILD OUT CONFIG...
#   tools/reference/speed_vs_torch.sh build /tmp/speed config/servod.yaml config/servod-2coil.yaml \
#       config/servod-4coil.yaml config/servod-phase-current.yaml
set -euo pipefail
if [ "$#" -lt 3 ]; then
  echo "usage: $0 BUILD OUT CONFIG..." >&2
  exit 2
fi
build=$1
out=$2
shift 2
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
timed() {  # timed LOG COMMAND...: runs it, appends "wall_s cpu_s" to LOG.time
  local log=$1
  shift
  /usr/bin/time -f '%e %U %S' -o "$log.time" "$@" > "$log" 2>&1 || {
    echo "failed: $*; see $log" >&2
    exit 1
  }
  awk '{printf "%.2f %.2f\n", $1, $2 + $3}' "$log.time"
}
{
  echo "| configuration | coil sets | ours wall [s] | ours CPU [s] | torch wall [s] | torch CPU [s] | ratio wall | ratio CPU | scipy wall [s] | scipy CPU [s] | ratio wall | ratio CPU | ours validation score | load before / after |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
} > "$out/speed.md"
for config in "$@"; do
  name=$(basename "$config" .yaml)
  dir="$out/$name"
  mkdir -p "$dir"
  load_before=$(cut -d' ' -f1 /proc/loadavg)
  # The experiments (and the commissioning's own models, not used here).
  "$build/bin/clm" commission --config "$config" --out "$dir/commission" --no-plots > "$dir/commission.log" 2>&1
  csv="$dir/commission/experiments.csv"
  # clm identify reads the motor description the configuration names.
  motor_file=$(sed -n 's/^motor_file: *\([^ #]*\).*/\1/p' "$config")
  motor=$config
  [ -n "$motor_file" ] && motor=$(dirname "$config")/$motor_file
  read -r ours_wall ours_cpu < <(timed "$dir/ours.log" "$build/bin/clm" identify --motor "$motor" --data "$csv" \
                                        --output "$dir/model-ours.yaml")
  read -r torch_wall torch_cpu < <(timed "$dir/torch.log" /usr/bin/python3 "$here/pgnn_torch.py" --data "$csv" \
                                          --motor "$config" --out "$dir/model-torch.yaml" --report "$dir/torch.json")
  read -r scipy_wall scipy_cpu < <(timed "$dir/scipy.log" /usr/bin/python3 "$here/pgnn_torch.py" --data "$csv" \
                                          --motor "$config" --out "$dir/model-scipy.yaml" --report "$dir/scipy.json" \
                                          --optimiser scipy)
  load_after=$(cut -d' ' -f1 /proc/loadavg)
  coil_sets=$(grep -c '^coil set [0-9]*:' "$dir/torch.log")
  score=$(sed -n 's/^capacity: .*validation score \([0-9.e+-]*\) *chosen$/\1/p' "$dir/ours.log")
  ratio() { awk -v t="$1" -v o="$2" 'BEGIN{printf "%.1fx", t / o}'; }
  echo "| $name | $coil_sets | $ours_wall | $ours_cpu | $torch_wall | $torch_cpu | $(ratio "$torch_wall" "$ours_wall") | $(ratio "$torch_cpu" "$ours_cpu") | $scipy_wall | $scipy_cpu | $(ratio "$scipy_wall" "$ours_wall") | $(ratio "$scipy_cpu" "$ours_cpu") | $score | $load_before / $load_after |" >> "$out/speed.md"
  tail -n 1 "$out/speed.md"
done
echo "machine: $(nproc) CPUs, $(sed -n 's/^model name\s*: //p' /proc/cpuinfo | head -1); $(date -u +%Y-%m-%dT%H:%MZ); commit $(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)" >> "$out/speed.md"
cat "$out/speed.md"
