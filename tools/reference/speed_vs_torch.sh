#!/usr/bin/env bash
# `clm identify --model pgnn` with its defaults (capacity selection and
# nuisance terms included) against the PyTorch reference training the paper's
# 2/16 PGNN (tools/reference/pgnn_torch.py, its defaults: L-BFGS, strong
# Wolfe, 5 restarts of 200 iterations, 5000 more on the best) and against
# the same training by an independent L-BFGS (SciPy's L-BFGS-B,
# `--optimiser scipy`), on the same experiments, one motor after the other;
# ours first, then the two references, in the same run. Wall and CPU time (user + system, every thread) of each
# process from GNU time; the ratio reference/ours of each. Prints a Markdown
# table and writes OUT/speed.md. REFERENCES (default "torch scipy") chooses
# the references run.
#
#   tools/reference/speed_vs_torch.sh BUILD OUT CONFIG...
#   tools/reference/speed_vs_torch.sh build /tmp/speed config/servod.yaml config/servod-2coil.yaml \
#       config/servod-4coil.yaml config/servod-phase-current.yaml
#   REFERENCES=scipy tools/reference/speed_vs_torch.sh build /tmp/speed-scipy config/servod.yaml
set -euo pipefail
if [ "$#" -lt 3 ]; then
  echo "usage: [REFERENCES=\"torch scipy\"] $0 BUILD OUT CONFIG..." >&2
  exit 2
fi
read -r -a references <<< "${REFERENCES:-torch scipy}"
for reference in "${references[@]}"; do
  case $reference in
    torch | scipy) ;;
    *) echo "$0: REFERENCES: '$reference' is neither torch nor scipy" >&2; exit 2 ;;
  esac
done
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
  header="| configuration | coil sets | ours wall [s] | ours CPU [s] |"
  rule="|---|---|---|---|"
  for reference in "${references[@]}"; do
    header+=" $reference wall [s] | $reference CPU [s] | ratio wall | ratio CPU |"
    rule+="---|---|---|---|"
  done
  echo "$header ours' validation score | load before / after |"
  echo "$rule---|---|"
} > "$out/speed.md"
ratio() { awk -v t="$1" -v o="$2" 'BEGIN{printf "%.1fx", t / o}'; }
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
  [ -n "$ours_cpu" ] || exit 1
  row="| $name | COIL_SETS | $ours_wall | $ours_cpu |"
  for reference in "${references[@]}"; do
    read -r wall cpu < <(timed "$dir/$reference.log" /usr/bin/python3 "$here/pgnn_torch.py" --data "$csv" \
                                --motor "$config" --out "$dir/model-$reference.yaml" --report "$dir/$reference.json" \
                                --optimiser "$reference")
    [ -n "$cpu" ] || exit 1
    row+=" $wall | $cpu | $(ratio "$wall" "$ours_wall") | $(ratio "$cpu" "$ours_cpu") |"
    coil_sets=$(grep -c '^coil set [0-9]*:' "$dir/$reference.log")
  done
  load_after=$(cut -d' ' -f1 /proc/loadavg)
  score=$(sed -n 's/^capacity: .*validation score \([0-9.e+-]*\) *chosen$/\1/p' "$dir/ours.log")
  echo "${row/COIL_SETS/$coil_sets} $score | $load_before / $load_after |" >> "$out/speed.md"
  tail -n 1 "$out/speed.md"
done
echo "machine: $(nproc) CPUs, $(sed -n 's/^model name\s*: //p' /proc/cpuinfo | head -1); $(date -u +%Y-%m-%dT%H:%MZ); commit $(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)" >> "$out/speed.md"
cat "$out/speed.md"
