#!/usr/bin/env bash
# The checks that need a GPU, in one short run (for a lent device machine; see the README's "Tests").
#   bash scripts/gpu_check.sh            # logs to $OUT (the device tool's folder) or ./out/gpu_check
# 1. the whole test suite on the CPU and on cuda:0 (the device fixture runs every device test on both);
# 2. the demo scene rendered in every mode on cuda:0, compared with the CPU image (mean absolute 8-bit error);
# 3. a 2 s budgeted replay on cuda:0 with its summary, and one with every issue-15 switch on;
# 4. the raster, trace and budget benchmarks on cuda:0 for two shared scenes (where the shared scenes are
#    at hand: WARP_HYBRID_SHARED_SCENES or ../shared/scenes), one table each, in bench.txt.
set -uo pipefail
cd "$(dirname "$0")/.."
LOG="${OUT:-out/gpu_check}"
mkdir -p "$LOG"
export PYTHONUNBUFFERED=1
make .venv/.installed-stamp >/dev/null  # the venv, as make test sets it up
nvidia-smi > "$LOG/nvidia-smi.txt" 2>&1 || true
WARP_HYBRID_TEST_DEVICES=cpu,cuda:0 .venv/bin/python -m pytest -q -p no:cacheprovider 2>&1 | tee "$LOG/tests.txt" | tail -5
for mode in raster hybrid full; do
  for dev in cpu cuda:0; do
    .venv/bin/warp-hybrid render scenes/cornell_glass.usda -o "$LOG/${mode}_${dev/:/}.png" --mode "$mode" \
      --device "$dev" --exposure 0 --gaze 0.4,0.5 2>&1 | tail -1 | tee -a "$LOG/renders.txt"
  done
  .venv/bin/python - "$LOG/${mode}_cpu.png" "$LOG/${mode}_cuda0.png" <<'PY' | tee -a "$LOG/renders.txt"
import sys, cv2, numpy as np
a, b = (cv2.imread(p).astype(np.int16) for p in sys.argv[1:3])
print(f"{sys.argv[2]}: mean |cpu - cuda| = {np.abs(a - b).mean():.3f} (8-bit), max {np.abs(a - b).max()}")
PY
done
.venv/bin/warp-hybrid replay scenes/cornell_glass.usda --gaze trace:scenes/traces/demo_gaze.csv --fps 30 \
  --duration 2 --device cuda:0 --out "$LOG/replay.mp4" --stats "$LOG/replay.csv" 2>&1 | tee "$LOG/replay.txt" | tail -6
.venv/bin/warp-hybrid replay scenes/cornell_glass.usda --gaze trace:scenes/traces/demo_gaze.csv --fps 30 \
  --duration 2 --device cuda:0 --ring --reuse --probes --shadow-maps --saccade --out "$LOG/replay_switches.mp4" \
  --stats "$LOG/replay_switches.csv" 2>&1 | tee "$LOG/replay_switches.txt" | tail -6
SCENES="${WARP_HYBRID_SHARED_SCENES:-../shared/scenes}"
if [ -f "$SCENES/manifest.json" ]; then
  for bench in bench_raster bench_trace bench_budget; do
    echo "## $bench on cuda:0" | tee -a "$LOG/bench.txt"
    .venv/bin/python "scripts/$bench.py" --scenes staircase classroom --size 640x480 --repeats 3 --device cuda:0 \
      2>&1 | tee -a "$LOG/bench.txt" | tail -8
  done
else
  echo "benchmarks skipped: no shared scenes at $SCENES" | tee -a "$LOG/bench.txt"
fi
