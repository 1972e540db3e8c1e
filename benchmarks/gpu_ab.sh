# A/B timing in one device call: this tree against another commit's engine, alternating so that both see the same
# machine state. Prepare the other side on the host first (it is untracked, so it travels with the tree):
#
#     rm -rf _ab && mkdir _ab && git archive REF warpdem scenes calibration benchmarks | tar x -C _ab
#
# then, on the GPU machine after its staging (see the project's guide):
#
#     sh benchmarks/gpu_ab.sh ringing 2        # the ringing batch (13 worlds, a calibration's advance), 2 rounds
#     sh benchmarks/gpu_ab.sh bed 1            # the deposited bed at 1 M and 4 M spheres, contacts by sphere and
#                                              # by pair (this tree only; the other side times its default)
#
# JSON lines under $OUT (ab_<what>_<side>.jsonl); carry benchmarks/.beds for the bed, or it is deposited again.
# Delete _ab afterwards.
OUT=${OUT:-/tmp/gpu_ab}; mkdir -p "$OUT"
what=${1:-ringing}; rounds=${2:-1}
[ -d _ab/benchmarks ] || { echo "no _ab/: archive the other commit first (see the top of this script)"; exit 2; }
[ -d benchmarks/.beds ] && mkdir -p _ab/benchmarks/.beds && cp -n benchmarks/.beds/* _ab/benchmarks/.beds/ 2>/dev/null
r=1
while [ $r -le "$rounds" ]; do
  for side in new ref; do
    dir=.; [ $side = ref ] && dir=_ab
    if [ "$what" = ringing ]; then
      (cd $dir/benchmarks && timeout 90 python3 step_profile.py --device cuda --scene ringing --advance --worlds 13 \
        --steps 11400 --json "$OUT/ab_ringing_$side.jsonl" 2>&1 | grep -E "^ringing|world_steps," | head -2)
    else
      ct="sphere pair"; [ $side = ref ] && ct=""
      (cd $dir/benchmarks && timeout 150 python3 bed_throughput.py --device cuda --sizes 1000000 4000000 \
        ${ct:+--contact-threads $ct} --json "$OUT/ab_bed_$side.jsonl" 2>&1 | grep '"engine"' | cut -c1-220)
    fi
  done
  r=$((r + 1))
done
