#!/usr/bin/env bash
# Prepare, on this machine, what a lent GPU machine lacks for the GPU benchmarks, in .gpu/ (kept
# out of git by .git/info/exclude; the device tool carries it): wheels of deik's pure-Python
# dependencies its image does not hold (yourdfpy, trimesh), and the shared robots and clips the
# benchmarks read from ../shared/data. Then it prints the command to give the device tool
# (docs/performance.md, "Running the GPU parts").
set -euo pipefail
cd "$(dirname "$0")/.."
grep -qx '/.gpu/' .git/info/exclude || echo '/.gpu/' >> .git/info/exclude
rm -rf .gpu
mkdir -p .gpu/wheels .gpu/data/humanoid
python3 -m pip download --quiet --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
    --platform manylinux_2_28_x86_64 --platform manylinux2014_x86_64 -d .gpu/wheels \
    yourdfpy==0.0.60 trimesh==5.2.0
cp -r ../shared/data/robots .gpu/data/
cp ../shared/data/humanoid/humanoid3d_walk.bvh ../shared/data/humanoid/humanoid3d_walk.segments.json .gpu/data/humanoid/
du -sh .gpu
cat <<'RUN'
Device tool: run(carry=[".gpu"], timeout_s=600, command=
  "python3 -m pip install -q --no-index --no-deps --target /tmp/site .gpu/wheels/*.whl && export PYTHONPATH=/tmp/site:src PYTHONUNBUFFERED=1 && mkdir -p ../shared && cp -r .gpu/data ../shared/ && python3 -m pytest -q tests/test_cuda.py tests/test_bench_gpu.py 2>&1 | tee $OUT/tests.log; python3 -m benchmarks.run_all --device gpu --out /tmp/gpu 2>&1 | tee $OUT/run_all.log; tar czf $OUT/gpu.tgz -C /tmp gpu")
RUN
