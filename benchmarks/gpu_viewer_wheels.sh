#!/usr/bin/env bash
# The viewer's wheels for the offline GPU machine (Python 3.12, uploads of at most 64 MiB a call), after the
# project's guide's Warp staging: rerun-sdk's wheel alone is 170 MB, so without this the viewer tests
# (tests/test_viewer.py) skip there. Run once from the project root on this machine:
#
#     bash benchmarks/gpu_viewer_wheels.sh
#
# It downloads rerun-sdk and its dependencies, splits them into five git-ignored folders .gpuD/ ... .gpuH/ (47 MiB
# each, so each fits one call beside the working tree) and writes a stage.sh in each. Then, on the warm GPU machine
# after .gpuC's call, five calls in a row (carry [".gpuD"] with `sh .gpuD/stage.sh`, ... [".gpuH"] with
# `sh .gpuH/stage.sh`); the last one checks the parts' checksum and installs the wheels into /root/site, where
# /root/gpu-env.sh looks. Then: WARPDEM_TEST_DEVICE=cuda python3 -m pytest tests/test_viewer.py
set -euo pipefail
RERUN_VERSION="${RERUN_VERSION:-$(python3 -c 'import rerun; print(rerun.__version__)' 2>/dev/null || echo 0.41.0)}"
root="$(git rev-parse --show-toplevel)"
cd "$root"
excl="$(git rev-parse --git-path info/exclude)"
dirs=".gpuD .gpuE .gpuF .gpuG .gpuH"
tmp="$(mktemp -d)"
python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
  --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 -d "$tmp/w" \
  "rerun-sdk==$RERUN_VERSION" pyarrow psutil attrs pillow typing_extensions
(cd "$tmp/w" && tar cf "$tmp/rr.tar" ./*.whl)
split -b 47m -d "$tmp/rr.tar" "$tmp/rr.part."
n=$(ls "$tmp"/rr.part.* | wc -l)
[ "$n" -le 5 ] || { echo "gpu_viewer_wheels.sh: the wheels need $n parts, more than the 5 folders"; exit 1; }
sha="$(sha256sum "$tmp/rr.tar" | cut -d' ' -f1)"
i=0; last=""
for d in $dirs; do
  grep -qxF "/$d/" "$excl" 2>/dev/null || echo "/$d/" >> "$excl"
  rm -rf "$d"
  part="$tmp/rr.part.0$i"
  [ -f "$part" ] || break
  mkdir -p "$d"; mv "$part" "$d/"
  printf 'set -e\nmkdir -p /root/rr-parts && cp %s/rr.part.* /root/rr-parts/ && ls /root/rr-parts\n' "$d" > "$d/stage.sh"
  last="$d"; i=$((i + 1))
done
cat >> "$last/stage.sh" <<EOS
cat /root/rr-parts/rr.part.0* > /root/rr.tar && echo "$sha  /root/rr.tar" | sha256sum -c -
mkdir -p /root/rrw && tar xf /root/rr.tar -C /root/rrw
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /root/site /root/rrw/*.whl
PYTHONPATH=/root/site python3 -c "import rerun, pyarrow; print('rerun', rerun.__version__)"
EOS
rm -rf "$tmp"
echo "staged in $i folders, the last $last: run their stage.sh in order on the warm GPU machine"
