#!/usr/bin/env bash
# Ray for the offline GPU machine (Python 3.12, uploads of at most 64 MiB with the working tree, about 30 MB of
# it): its wheel (~79 MB) split into 20 MB parts over four git-ignored folders of its own, .gpuRayA/ ... .gpuRayD/
# (the last with Ray's dependencies, and the install), apart from the Warp wheel's .gpuA/ ... folders of
# ../shared/tools/gpu-wheels.sh. From the project root, once:
#   bash benchmarks/ray_wheels.sh            # or RAY_WHEEL=path/to/ray-*.whl to split a wheel already here
# Then, on the warm GPU machine after Warp is staged, four calls: carry [".gpuRayA"] with `sh .gpuRayA/stage.sh`;
# the same with B and C; carry [".gpuRayD"] with `sh .gpuRayD/stage.sh && . /root/gpu-env.sh && <work>` (Ray
# installs into /root/site beside Warp).
set -euo pipefail
RAY_VERSION="${RAY_VERSION:-2.60.0}"
cd "$(git rev-parse --show-toplevel)"
excl="$(git rev-parse --git-path info/exclude)"; mkdir -p "$(dirname "$excl")"
tmp="$(mktemp -d)"
python3 -m pip download -q --only-binary=:all: --python-version 3.12 --implementation cp \
  --platform manylinux2014_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux_2_28_x86_64 \
  -d "$tmp" "ray==${RAY_VERSION}"
whl="$(ls "$tmp"/ray-*.whl)"
if [ -n "${RAY_WHEEL:-}" ]; then cp "$RAY_WHEEL" "$whl"; fi
name="$(basename "$whl")"; sha="$(sha256sum "$whl" | cut -d' ' -f1)"
dirs=".gpuRayA .gpuRayB .gpuRayC .gpuRayD"
for d in $dirs; do
  grep -qxF "/$d/" "$excl" 2>/dev/null || echo "/$d/" >> "$excl"
  rm -rf "$d"; mkdir -p "$d"
done
split -b 20000000 -d "$whl" "$tmp/ray.part."
set -- $dirs
for part in "$tmp"/ray.part.*; do mv "$part" "$1/"; shift; done
for w in "$tmp"/*.whl; do [ "$w" = "$whl" ] || mv "$w" .gpuRayD/; done
for d in .gpuRayA .gpuRayB .gpuRayC; do echo "mkdir -p /root/gpu-parts && cp $d/ray.part.* /root/gpu-parts/" > $d/stage.sh; done
cat > .gpuRayD/stage.sh <<EOS
set -e
mkdir -p /root/gpu-parts && cp .gpuRayD/ray.part.* /root/gpu-parts/
cat /root/gpu-parts/ray.part.0* > /root/$name
echo "$sha  /root/$name" | sha256sum -c -
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /root/site /root/$name .gpuRayD/*.whl
PYTHONPATH=/root/site python3 -c "import ray; print('ray', ray.__version__)"
EOS
rm -rf "$tmp"
du -sh $dirs
