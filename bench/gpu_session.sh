#!/usr/bin/env bash
# One device session's plan: install the project, run the test suite on CPU + CUDA, benchmark.
# Run on the GPU machine after `source .gpu/p2/stage2.sh` (see ../shared/gpu/README.md); logs go to $OUT.
set -u
OUT=${OUT:-/tmp/out}
mkdir -p "$OUT"
python3 -m pip install -q --no-deps --no-build-isolation --no-index --upgrade --target /opt/wstage/proj . > "$OUT/install.log" 2>&1 \
  || { cat "$OUT/install.log"; exit 1; }
export PYTHONPATH=/opt/wstage/proj:${PYTHONPATH}
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv > "$OUT/gpu.txt" 2>&1
cp -r tests /tmp/wc_tests && cp -r examples /tmp/examples && cp -r docs /tmp/docs
(cd /tmp && timeout 420 python3 -m pytest -q -rs -p no:cacheprovider /tmp/wc_tests ${PYTEST_ARGS:-} 2>&1 | tee "$OUT/pytest.log" | tail -25)
(cd /tmp && timeout 300 python3 "$OLDPWD/bench/bench_normal.py" --device cuda:0 ${BENCH_ARGS:-} --json "$OUT/bench_gpu.json" 2>&1 | tee "$OUT/bench_gpu.log")
# Table 2 (adhesionless, 12 cells) at 256 x 256 on the GPU, timed (TABLE2=1 to run it)
[ "${TABLE2:-0}" = 1 ] && (cd /tmp && /usr/bin/time -v timeout 400 python3 -m warpcontact.cli table2 --no-adhesion --n 256 --device cuda:0 \
   --out "$OUT/table2_gpu" 2>&1 | tail -40 > "$OUT/table2_gpu.log"; cat "$OUT/table2_gpu.log" | tail -16)
