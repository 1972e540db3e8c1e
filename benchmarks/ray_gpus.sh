# A draught calibration (cpu scale, 85 individuals, no screening) three ways on one machine with two GPUs:
# in process on GPU 0, on two Ray workers (one per GPU), on one Ray worker (GPU 0), with nvidia-smi sampling both
# GPUs; then benchmarks/ray_compare.py. Run from the project root on the GPU machine (after . /root/gpu-env.sh,
# with Ray staged by benchmarks/ray_wheels.sh):
#   sh benchmarks/ray_gpus.sh [SCALE] [LIMIT_S] [RUNS] [GA_ARGS]   # results in $OUT/ray (or /tmp/ray)
# RUNS: which of the three, e.g. "a b c" (default) or "b c"; GA_ARGS e.g. "--generations 1 --population 10".
S=${1:-cpu}; L=${2:-240}; RUNS=${3:-a b c}; GA=${4:-}
R=${OUT:-/tmp}/ray; mkdir -p $R/runs
nvidia-smi -L > $R/gpus.txt; cat $R/gpus.txt
nvidia-smi --query-gpu=timestamp,index,utilization.gpu,memory.used --format=csv,noheader,nounits -lms 500 \
  > $R/util.csv 2>/dev/null &
SMI=$!
cal() {  # name, CUDA_VISIBLE_DEVICES, extra args
  echo "$(date +%s.%N) $1_start" >> $R/marks.txt
  CUDA_VISIBLE_DEVICES=$2 timeout -s INT $L python3 -m calibration.cli calibrate draught --assembly C --scale $S \
    --device cuda --no-screen --beds $R/beds --out $R/runs/$1 $3 $GA > $R/$1.log 2>&1
  echo "rc=$?" >> $R/$1.log
  echo "$(date +%s.%N) $1_end" >> $R/marks.txt
  tail -3 $R/$1.log
}
case " $RUNS " in *" a "*) cal a_local_1gpu 0 "";; esac
case " $RUNS " in *" b "*) cal b_ray_2gpu 0,1 "--ray-workers 2";; esac
case " $RUNS " in *" c "*) cal c_ray_1gpu 0 "--ray-workers 1";; esac
kill $SMI
python3 benchmarks/ray_compare.py $R/runs --util $R/util.csv --marks $R/marks.txt
rm -rf $R/beds
