# A/B timing in one device call: this tree against other engines, alternating so that all see the same machine
# state. Each other side is a directory _ab*/ in the project root holding warpdem/, scenes/, calibration/ and
# benchmarks/, prepared on the host, for example another commit:
#
#     rm -rf _ab && mkdir _ab && git archive REF warpdem scenes calibration benchmarks | tar x -C _ab
#
# or the upper-bound variants of the ringing step's body stage (benchmarks/ab_variants.py). Git ignores _ab*/:
# name each in the call's carry. Then, on the GPU machine after its staging (see the project's guide):
#
#     sh benchmarks/gpu_ab.sh ringing 2   # the ringing batch (13 worlds, a calibration's advance), 2 rounds
#     sh benchmarks/gpu_ab.sh bed 1       # the deposited bed at 1 M and 4 M spheres, contacts by sphere and by pair
#                                         # (this tree; the other sides time their default)
#     BED=file.npz sh benchmarks/gpu_ab.sh paperbed  # this tree only: a saved bed (a paper-scale run's) alone and
#                                         # tiled to 4 M spheres, in deposition and in Morton order, by sphere and pair
#     sh benchmarks/gpu_ab.sh profile     # this tree only: Nsight Compute's per-line stall samples of one launch of
#                                         # world_steps_kernel (ringing) and of each contact kernel (1 M bed)
#
# JSON lines and reports under $OUT (ab_<what>_<side>.jsonl, *.ncu-rep, *_source.csv); carry benchmarks/.beds for
# the bed, or it is deposited again. Delete the _ab* directories afterwards.
OUT=${OUT:-/tmp/gpu_ab}; mkdir -p "$OUT"
what=${1:-ringing}; rounds=${2:-1}
case "$what" in ringing|bed|paperbed|profile) ;;
  *) echo "gpu_ab.sh: what must be ringing, bed, paperbed or profile, got '$what'"; exit 2;; esac
if [ "$what" = paperbed ]; then
  [ -f "$BED" ] || { echo "gpu_ab.sh paperbed: BED must name a saved bed (.npz), got '$BED'"; exit 2; }
  BED=$(cd "$(dirname "$BED")" && pwd)/$(basename "$BED")
  cd benchmarks
  for order in "" --sorted; do
    timeout 200 python3 bed_throughput.py --device cuda --bed "$BED" --sizes 0 4000000 $order \
      --contact-threads sphere pair --json "$OUT/ab_paperbed.jsonl" 2>&1 | grep '"engine"' | cut -c1-240
  done
  exit 0
fi
if [ "$what" = profile ]; then
  cd benchmarks
  timeout 200 ncu -k regex:world_steps_kernel --launch-skip 3 --launch-count 1 --section SourceCounters \
    --section WarpStateStats --section LaunchStats --import-source yes -f -o "$OUT/ringing" \
    python3 step_profile.py --device cuda --scene ringing --advance --worlds 13 --steps 1140 --lineinfo \
    > "$OUT/ncu_ringing.log" 2>&1
  tail -3 "$OUT/ncu_ringing.log"
  ncu -i "$OUT/ringing.ncu-rep" --page source --csv --print-source cuda > "$OUT/ringing_source.csv" 2>&1
  ncu -i "$OUT/ringing.ncu-rep" --page details > "$OUT/ringing_details.txt" 2>&1
  for ct in sphere pair; do
    timeout 200 ncu -k "regex:sphere_${ct}_kernel" --launch-skip 50 --launch-count 1 --section SourceCounters \
      --section WarpStateStats --section MemoryWorkloadAnalysis --section SpeedOfLight --import-source yes -f \
      -o "$OUT/bed_$ct" python3 step_profile.py --device cuda --size 1000000 --steps 100 --contact-threads $ct \
      --lineinfo > "$OUT/ncu_bed_$ct.log" 2>&1
    tail -2 "$OUT/ncu_bed_$ct.log"
    ncu -i "$OUT/bed_$ct.ncu-rep" --page source --csv --print-source cuda > "$OUT/bed_${ct}_source.csv" 2>&1
    ncu -i "$OUT/bed_$ct.ncu-rep" --page details > "$OUT/bed_${ct}_details.txt" 2>&1
  done
  exit 0
fi
sides=". $(ls -d _ab*/ 2>/dev/null | tr -d /)"
[ "$sides" = ". " ] && { echo "no _ab*/ directory: prepare the other side first (see the top of this script)"; exit 2; }
for dir in $sides; do
  [ "$dir" != . ] && [ -d benchmarks/.beds ] && mkdir -p "$dir/benchmarks/.beds" && \
    cp -n benchmarks/.beds/* "$dir/benchmarks/.beds/" 2>/dev/null
done
r=1
while [ $r -le "$rounds" ]; do
  for dir in $sides; do
    side=new; [ "$dir" != . ] && side=$dir
    if [ "$what" = ringing ]; then
      echo "== $side"
      (cd "$dir/benchmarks" && timeout 90 python3 step_profile.py --device cuda --scene ringing --advance --worlds 13 \
        --steps 11400 --json "$OUT/ab_ringing_$side.jsonl" 2>&1 | grep -E "^ringing|world_steps," | head -2)
    else
      ct="sphere pair"; [ "$dir" != . ] && ct=""
      (cd "$dir/benchmarks" && timeout 150 python3 bed_throughput.py --device cuda --sizes 1000000 4000000 \
        ${ct:+--contact-threads $ct} --json "$OUT/ab_bed_$side.jsonl" 2>&1 | grep '"engine"' | cut -c1-220)
    fi
  done
  r=$((r + 1))
done
