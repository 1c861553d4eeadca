#!/usr/bin/env bash
# One device session's plan: install the project, then the parts asked for. Logs go to $OUT.
# Run on the GPU machine after `source .gpu/p2/stage2.sh` (see ../shared/gpu/README.md).
#   TESTS=1   the test suite on CPU + CUDA (PYTEST_ARGS)
#   BENCH=1   bench_normal.py on cuda:0 (BENCH_ARGS)
#   ITER=1    bench_iteration.py on cuda:0, with and without adhesion (ITER_ARGS)
#   TABLE2=1  warpcontact table2 (both columns) at 256 x 256 on cuda:0, timed (TABLE2_ARGS); into
#             TABLE2_DIR (default $OUT/table2_gpu; a folder outside $OUT, kept while the machine is
#             warm, lets the next call resume the table), copied to $OUT/table2_gpu
#   PARTS=1   bench/iteration_parts.py on cuda:0 (PARTS_ARGS, default --sizes 1024 2048 4096)
#   SCALE=1   bench/scale_check.py on cuda:0 (SCALE_ARGS, e.g. --sizes 8191 --dtype float64)
#   FIGS=1    warpcontact figure for every examples/figure*.toml on cuda:0 (the paper's Figures 1 and 2)
#   PROFILE=1 bench/profile_table2_cell.py on cuda:0 (PROFILE_ARGS, default --n 256): one Table 2 cell by phase
#   LAYOUTS=1 bench/fft_small_sizes.py on cuda:0 (LAYOUTS_ARGS): cuFFT pair, pruned against 2-D plans, by size
#   SETUP=1   bench/setup_time.py on cuda:0 (SETUP_ARGS, default --sizes 2048 4096 8191): model set-up times
#   SIDE=DIR  the same benchmarks from another tree (DIR: e.g. the last commit, `git archive HEAD warpcontact
#             kernels bench pyproject.toml README.md | tar -x -C .gpu/old`, carried), alternating with this
#             tree's in one run: bench_iteration.py (SIDE_ARGS, default --sizes 1024 2048 4096
#             --compare-up-to 0) ROUNDS times (default 2), each tree's log in $OUT/side_{old,new}_K.log;
#             SIDE_SCRIPT=this: both trees run this tree's bench_iteration.py (the same measurement)
#   REDUCE=1  bench/reduction_launch.py on cuda:0 (REDUCE_ARGS, default --sizes 1024 2048 4096), warm and --cold
#   TURNS=1   bench/graph_turns.py on cuda:0 (TURNS_ARGS): what a turn of the device loop costs
#   SCALING=1 bench/scaling.py on cuda:0 (SCALING_ARGS, default --sizes 256 1024 4096 --dtypes float64
#             --rows coupled-window coupled-whole): iterations and time per step against n
#   API=1     bench/api_parts.py on cuda:0 (API_ARGS, default --sizes 4096 --fields none): wc.solve by part
#   ADH=W     bench/adhesion_sensitivity.py on W CPU workers, in the background while the rest runs
#             (its cells.jsonl is kept in $OUT/adh; a copy in bench_results/adh/ is resumed)
set -u
OUT=${OUT:-/tmp/out}
mkdir -p "$OUT"
ROOT=$PWD
python3 -m pip install -q --no-deps --no-build-isolation --no-index --upgrade --target /opt/wstage/proj . > "$OUT/install.log" 2>&1 \
  || { cat "$OUT/install.log"; exit 1; }
export PYTHONPATH=/opt/wstage/proj:${PYTHONPATH}
# the device machine sets PYTHONDONTWRITEBYTECODE=1: without this every process there compiled
# warpcontact's and Warp's sources anew (0.9 s of a 2.2 s Hertz n = 1024 `warpcontact solve` on an
# H100); pip compiles them when it installs a wheel, as a user's machine has them
python3 -m compileall -q /opt/wstage/proj /opt/wstage/site > "$OUT/compileall.log" 2>&1
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv > "$OUT/gpu.txt" 2>&1
if [ "${ADH:-0}" != 0 ]; then
  mkdir -p "$OUT/adh"
  [ -f "$ROOT/bench_results/adh/cells.jsonl" ] && cp "$ROOT/bench_results/adh/cells.jsonl" "$OUT/adh/"
  (cd /tmp && timeout "${ADH_TIMEOUT:-560}" python3 "$ROOT/bench/adhesion_sensitivity.py" --out "$OUT/adh" --workers "$ADH" \
     ${ADH_ARGS:-} > "$OUT/adh/run.log" 2>&1) &
  ADH_PID=$!
fi
if [ "${TESTS:-0}" = 1 ]; then
  rm -rf /tmp/wc_tests && cp -r tests /tmp/wc_tests && cp -r examples /tmp/examples && cp -r docs /tmp/docs
  (cd /tmp && timeout "${TESTS_TIMEOUT:-420}" python3 -m pytest -q -rs -p no:cacheprovider /tmp/wc_tests ${PYTEST_ARGS:-} 2>&1 \
     | tee "$OUT/pytest.log" | tail -25; echo "pytest exit status: ${PIPESTATUS[0]}" | tee -a "$OUT/pytest.log")
fi
[ "${BENCH:-0}" = 1 ] && (cd /tmp && timeout 300 python3 "$ROOT/bench/bench_normal.py" --device cuda:0 ${BENCH_ARGS:-} \
   --json "$OUT/bench_gpu.json" 2>&1 | tee "$OUT/bench_gpu.log")
if [ "${ITER:-0}" = 1 ]; then
  (cd /tmp && timeout "${ITER_TIMEOUT:-240}" python3 "$ROOT/bench/bench_iteration.py" --device cuda:0 ${ITER_ARGS:-} --json "$OUT/iter_gpu.json" 2>&1 \
     | tee "$OUT/iter_gpu.log")
  (cd /tmp && timeout "${ITER_ADH_TIMEOUT:-200}" python3 "$ROOT/bench/bench_iteration.py" --device cuda:0 --adhesion ${ITER_ARGS:-} \
     --json "$OUT/iter_gpu_adh.json" 2>&1 | tee "$OUT/iter_gpu_adh.log")
fi
if [ -n "${SIDE:-}" ]; then
  python3 -m pip install -q --no-deps --no-build-isolation --no-index --upgrade --target /opt/wstage/old "$SIDE" \
    > "$OUT/install_old.log" 2>&1 || { cat "$OUT/install_old.log"; exit 1; }
  SIDE_DIR=$(cd "$SIDE" && pwd)
  for k in $(seq 1 "${ROUNDS:-2}"); do
    for tree in old new; do
      if [ "$tree" = old ] && [ "${SIDE_SCRIPT:-}" != this ]; then path=/opt/wstage/old; script="$SIDE_DIR/bench/bench_iteration.py"
      elif [ "$tree" = old ]; then path=/opt/wstage/old; script="$ROOT/bench/bench_iteration.py"
      else path=/opt/wstage/proj; script="$ROOT/bench/bench_iteration.py"; fi
      (cd /tmp && PYTHONPATH=$path:${PYTHONPATH#/opt/wstage/proj:} timeout "${SIDE_TIMEOUT:-200}" python3 "$script" \
         --device cuda:0 ${SIDE_ARGS:---sizes 1024 2048 4096 --compare-up-to 0} > "$OUT/side_${tree}_$k.log" 2>&1)
      echo "== $tree, round $k"; tail -n +2 "$OUT/side_${tree}_$k.log"
    done
  done
fi
if [ "${SCALING:-0}" = 1 ]; then
  (cd /tmp && timeout "${SCALING_TIMEOUT:-400}" python3 "$ROOT/bench/scaling.py" --device cuda:0 --fft cupy \
     ${SCALING_ARGS:---sizes 256 1024 4096 --dtypes float64 --rows coupled-window coupled-whole} \
     --json "$OUT/scaling_gpu.json" 2>&1 | tee "$OUT/scaling_gpu.log")
fi
if [ "${API:-0}" = 1 ]; then
  (cd /tmp && timeout "${API_TIMEOUT:-300}" python3 "$ROOT/bench/api_parts.py" --device cuda:0 --fft cupy \
     ${API_ARGS:---sizes 4096 --fields none} 2>&1 | tee "$OUT/api_parts.log")
fi
if [ "${REDUCE:-0}" = 1 ]; then
  for mode in "" --cold; do
    (cd /tmp && timeout "${REDUCE_TIMEOUT:-200}" python3 "$ROOT/bench/reduction_launch.py" --device cuda:0 \
       ${REDUCE_ARGS:---sizes 1024 2048 4096} $mode 2>&1 | tee -a "$OUT/reduction_launch.log")
  done
fi
if [ "${TURNS:-0}" = 1 ]; then
  (cd /tmp && timeout "${TURNS_TIMEOUT:-120}" python3 "$ROOT/bench/graph_turns.py" --device cuda:0 ${TURNS_ARGS:-} 2>&1 \
     | tee "$OUT/graph_turns.log")
fi
if [ "${PARTS:-0}" = 1 ]; then
  (cd /tmp && timeout "${PARTS_TIMEOUT:-200}" python3 "$ROOT/bench/iteration_parts.py" --device cuda:0 \
     ${PARTS_ARGS:---sizes 1024 2048 4096} 2>&1 | tee "$OUT/parts_gpu.log")
fi
if [ "${SCALE:-0}" = 1 ]; then
  (cd /tmp && timeout "${SCALE_TIMEOUT:-300}" python3 "$ROOT/bench/scale_check.py" --device cuda:0 ${SCALE_ARGS:-} \
     --json "$OUT/scale_gpu.json" 2>&1 | tee "$OUT/scale_gpu.log")
fi
if [ "${TABLE2:-0}" = 1 ]; then
  T2=${TABLE2_DIR:-$OUT/table2_gpu}
  (cd /tmp && /usr/bin/time -v timeout "${TABLE2_TIMEOUT:-400}" python3 -m warpcontact.cli table2 --n 256 --device cuda:0 \
     ${TABLE2_ARGS:-} --out "$T2" > "$OUT/table2_gpu.log" 2>&1; tail -40 "$OUT/table2_gpu.log")
  [ "$T2" != "$OUT/table2_gpu" ] && cp -r "$T2" "$OUT/table2_gpu"
fi
if [ "${PROFILE:-0}" = 1 ]; then
  # the whole output goes to the log first (a pipe into head would cut the log short)
  (cd /tmp && timeout "${PROFILE_TIMEOUT:-240}" python3 "$ROOT/bench/profile_table2_cell.py" --device cuda:0 \
     ${PROFILE_ARGS:---n 256} > "$OUT/profile_cell.log" 2>&1; head -30 "$OUT/profile_cell.log")
fi
if [ "${LAYOUTS:-0}" = 1 ]; then
  (cd /tmp && timeout "${LAYOUTS_TIMEOUT:-200}" python3 "$ROOT/bench/fft_small_sizes.py" --device cuda:0 ${LAYOUTS_ARGS:-} \
     > "$OUT/fft_layouts.log" 2>&1; cat "$OUT/fft_layouts.log")
fi
if [ "${SETUP:-0}" = 1 ]; then
  (cd /tmp && timeout "${SETUP_TIMEOUT:-200}" python3 "$ROOT/bench/setup_time.py" --device cuda:0 \
     ${SETUP_ARGS:---sizes 2048 4096 8191} > "$OUT/setup.log" 2>&1; cat "$OUT/setup.log")
fi
if [ "${FIGS:-0}" = 1 ]; then
  mkdir -p "$OUT/figs"
  for f in examples/figure*.toml; do
    name=$(basename "$f" .toml)
    (cd /tmp && timeout "${FIGS_TIMEOUT:-120}" python3 -m warpcontact.cli figure "$ROOT/$f" --device cuda:0 --quiet \
       --out "$OUT/figs/$name" > "$OUT/figs/$name.log" 2>&1; echo "$name: exit $?" | tee -a "$OUT/figs/status.txt")
    rm -f "$OUT/figs/$name/fields.npz"  # large; the PNGs and result.json come back
  done
fi
if [ "${ADH:-0}" != 0 ]; then
  wait "$ADH_PID"
  tail -30 "$OUT/adh/run.log"
fi
