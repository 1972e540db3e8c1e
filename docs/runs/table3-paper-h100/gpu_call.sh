# One GPU call of this run (see README.md "Continuing"): the workflow runs in /root/t3, out of the synced tree.
# Usage: sh gpu_call.sh BUDGET_S [more reproduce options, e.g. --diagnosis-rounds 1]
R=/root/t3
if [ ! -f $R/workflow.json ]; then mkdir -p $R && cp -r docs/runs/table3-paper-h100/. $R/; fi
if [ -d docs/runs/table3-paper-h100/beds ]; then mkdir -p $R/beds && cp -n docs/runs/table3-paper-h100/beds/*.npz $R/beds/ 2>/dev/null; fi
B=${1:-540}; shift 2>/dev/null
python -m calibration.cli reproduce --workflow full --scale paper --out $R --budget $B "$@" > $OUT/log.txt 2>&1; echo "rc=$?" >> $OUT/log.txt
tar czf $OUT/state.tgz -C /root --exclude=t3/checkpoints --exclude=t3/beds t3
cp $R/beds/bed_paper_*.npz $OUT/ 2>/dev/null
ls -la $R/beds $R/checkpoints 2>/dev/null | tail -20
tail -15 $OUT/log.txt
if [ -n "$(ls -A $R/checkpoints 2>/dev/null)" ]; then tar czf - -C /root t3/checkpoints | split -b 9000000 - $OUT/ckpt.tgz.part.; ls -la $OUT; fi
