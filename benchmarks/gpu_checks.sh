# The CUDA checks and measurements of the engine issue in one device call (at most ~9 minutes), from the project
# root on the GPU machine after its staging (see the project's guide):
#
#     sh benchmarks/gpu_checks.sh            # results (test logs, JSON lines, calibration summaries) under $OUT
#
# Carry benchmarks/.beds (the cpu-scale bed, deposited once on this machine by bed_throughput.py) or the bed is
# deposited again there first.
# 1. the tests that compare CUDA runs with themselves, with Yade and with closed forms (WARPDEM_TEST_DEVICE=cuda),
#    stopped by SIGINT at their time limit so that pytest still prints which failed;
# 2. the deposited-bed throughput at 1, 4 and 16 M spheres and each op of a 4 M step;
# 3. the ringing batch of a calibration, each kernel's own time, and the two ringing calibrations of the engine
#    issue's goals (85 individuals: spring spheres < 60 s, linear < 15 s).
# The GPU image lacks meshio (VTK output) unless staged with it: the shear box and demo tests need it.
# It lacks rerun-sdk too: the viewer tests skip there unless benchmarks/gpu_viewer_wheels.sh's folders are staged.
#
#     sh benchmarks/gpu_checks.sh suite      # instead: the whole test suite on CUDA but tests/test_diagnosis.py,
#                                            # a test per worker (340 s on one H100 in session 24)
#     sh benchmarks/gpu_checks.sh suite diagnosis  # then tests/test_diagnosis.py in a call of its own (51 s)
#     sh benchmarks/gpu_checks.sh suite twin  # tests/test_twin_diagnosis.py (the Yade twin's hidden effects), its
#                                            # diagnoses checkpointed in WARPDEM_TWIN_DIAGNOSIS_DIR (default
#                                            # /root/twin_diagnosis): calls again on the warm machine resume them
#
#     sh benchmarks/gpu_checks.sh replicas   # instead: Table 3's replicas as worlds on CUDA: their tests, and a
#                                            # paper-scale rigid run of 4 worlds on one bed and on 4 replica beds
#     sh benchmarks/gpu_checks.sh split      # instead: where the paper-scale soil bin's GPU time goes (4 rigid
#                                            # worlds, 0.2 m): activities with the step's graph, then every kernel
#                                            # launched alone (--no-graphs), Warp's activity timing
OUT=${OUT:-/tmp/gpu_checks}; mkdir -p "$OUT"
export WARPDEM_TEST_DEVICE=cuda
if [ "$1" = "replicas" ]; then
  timeout -s INT 180 python3 -m pytest -q -n 8 --dist loadfile --tb=short -p no:cacheprovider -W ignore \
    tests/test_replica_beds.py tests/test_workflow.py -k "replica or group or paired or fit_poses or parked" > "$OUT/pytest_cuda_replicas.txt" 2>&1
  echo "rc=$?" >> "$OUT/pytest_cuda_replicas.txt"; tail -5 "$OUT/pytest_cuda_replicas.txt"
  unset WARPDEM_TEST_DEVICE
  cd benchmarks
  for flag in "" --replicas; do
    timeout 200 python3 soil_bin_throughput.py --device cuda --scale paper --worlds 4 --travel 0.2 $flag \
      --json "$OUT/results_soil_bin_cuda.jsonl" | cut -c1-400
  done
  exit 0
fi
if [ "$1" = "split" ]; then
  unset WARPDEM_TEST_DEVICE
  cd benchmarks
  for g in "" --no-graphs; do
    timeout 280 python3 soil_bin_throughput.py --device cuda --scale paper --worlds 4 --travel 0.2 --kernel-times 40 \
      $g --json "$OUT/soil_bin_split.jsonl" 2>&1 | grep -v -E "^Module|Kernel cache|cache/warp|^Warp|CUDA Toolkit|Devices:|\"c(pu|uda:0)\""
  done
  exit 0
fi
if [ "$1" = "suite" ]; then
  part=${2:-main}
  if [ "$part" = twin ]; then  # checkpointed: call again until it passes (2.5-3.5 min a data set on one H100, 6 sets)
    export WARPDEM_TWIN_DIAGNOSIS_DIR=${WARPDEM_TWIN_DIAGNOSIS_DIR:-/root/twin_diagnosis}; mkdir -p "$WARPDEM_TWIN_DIAGNOSIS_DIR"
    what="tests/test_twin_diagnosis.py"; workers=0  # one process: its module fixture diagnoses every set once
  elif [ "$part" = diagnosis ]; then what="tests/test_diagnosis.py"
  else what="tests --ignore tests/test_diagnosis.py --ignore tests/test_twin_diagnosis.py"; fi
  timeout -s INT 570 python3 -m pytest -q -n ${workers:-15} --dist load --tb=short -p no:cacheprovider -W ignore $what \
    > "$OUT/pytest_cuda_suite_$part.txt" 2>&1
  echo "suite $part rc=$?" >> "$OUT/pytest_cuda_suite_$part.txt"
  grep -E "FAILED|ERROR|passed|failed|rc=" "$OUT/pytest_cuda_suite_$part.txt" | tail -30
  exit 0
fi
timeout -s INT 200 python3 -m pytest -q -n 12 --dist loadfile --tb=short -p no:cacheprovider -W ignore \
  tests/test_determinism.py tests/test_worlds.py tests/test_yade.py tests/test_closed_form.py tests/test_dynamics.py \
  tests/test_rigs.py tests/test_checkpoint.py tests/test_broadphase.py > "$OUT/pytest_cuda.txt" 2>&1
echo "pytest rc=$?" >> "$OUT/pytest_cuda.txt"; tail -15 "$OUT/pytest_cuda.txt"
unset WARPDEM_TEST_DEVICE
python3 -m compileall -q /root/site warpdem scenes calibration > /dev/null 2>&1  # byte-code, as pip installs do
cd benchmarks
timeout 120 python3 bed_throughput.py --device cuda --sizes 1000000 4000000 16000000 --json "$OUT/results_bed_cuda.jsonl"
timeout 45 python3 step_profile.py --device cuda --size 4000000 --steps 100 --json "$OUT/step_profile_cuda.jsonl"
timeout 45 python3 step_profile.py --device cuda --scene ringing --worlds 13 --steps 2000 \
  --json "$OUT/step_profile_cuda.jsonl"
for w in 13 20; do  # the ringing batch advanced as a calibration does: staged, and a thread per world
  timeout 60 python3 step_profile.py --device cuda --scene ringing --advance --worlds $w --steps 11400 \
    --json "$OUT/step_profile_cuda.jsonl"
done
cd ..
for model in linear paper; do
  t0=$(date +%s)
  timeout 150 python3 -m calibration.cli calibrate ringing --quiet --device cuda --spring-model $model \
    --out "/tmp/gpu_checks_ringing_$model" --overwrite > "$OUT/calibrate_ringing_$model.txt" 2>&1
  echo "calibrate ringing --spring-model $model: rc=$? $(( $(date +%s) - t0 )) s" | tee -a "$OUT/calibrate_ringing_$model.txt"
done
