#!/usr/bin/env bash
# Retrain the shipped checkpoints: every model on our fixed OxIOD split (docs/results/split.md),
# identical CPU-budget hyper-parameters for all, weights stored as float16.
#   scripts/train_shipped.sh MINUTES MODEL [MODEL ...]
# Runs go to runs/oxiod/<model>/; the best checkpoint is copied to checkpoints/<model>-oxiod.*.
set -euo pipefail
cd "$(dirname "$0")/.."
minutes=$1; shift
oxiod=${FTIN_OXIOD:-../shared/data/oxiod}
train=("handheld/data1/syn/imu2.csv" "handheld/data1/syn/imu4.csv"
       "multi users/user2/syn/imu4.csv" "multi users/user2/syn/imu6.csv"
       "trolley/data1/syn/imu7.csv" "trolley/data2/syn/imu1.csv" "trolley/data2/syn/imu2.csv"
       "trolley/data2/syn/imu4.csv" "trolley/data2/syn/imu5.csv")
val=("handheld/data1/syn/imu3.csv" "multi users/user2/syn/imu5.csv" "trolley/data2/syn/imu3.csv")
args=()
for f in "${train[@]}"; do args+=(--data "$oxiod/$f"); done
for f in "${val[@]}"; do args+=(--val "$oxiod/$f"); done
for model in "$@"; do
  window=100 stride=10
  # RNIN runs its LSTM over 10 one-second sub-windows: a 10 s input window.
  [ "$model" = rnin ] && window=1000 stride=100
  out=runs/oxiod/$model
  .venv/bin/python -m ftin train --model "$model" "${args[@]}" --out "$out" --name "$model-oxiod" \
    --window $window --stride $stride --batch-size 128 --lr 1e-3 --max-minutes "$minutes" \
    --threads 1 --half --seed 0 --no-progress
  cp "$out/$model-oxiod.safetensors" "$out/$model-oxiod.json" checkpoints/
  vals=(); for f in "${val[@]}"; do vals+=(--data "$oxiod/$f"); done
  .venv/bin/python -m ftin evaluate --checkpoint "checkpoints/$model-oxiod" "${vals[@]}" --json "$out/val.json"
  .venv/bin/python -m ftin.train.model_card "checkpoints/$model-oxiod.json" "$out/val.json" \
    > "checkpoints/$model-oxiod.md"
done
