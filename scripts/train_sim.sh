#!/usr/bin/env bash
# Retrain the shipped FTIN-sim checkpoint on simulated walks (seeds disjoint from the app's samples).
#   scripts/train_sim.sh MINUTES
set -euo pipefail
cd "$(dirname "$0")/.."
minutes=$1
out=runs/sim
.venv/bin/python -m ftin sim --out $out/train --count 24 --duration-s 120 --seed 1000
.venv/bin/python -m ftin sim --out $out/val --count 3 --duration-s 120 --seed 2000
.venv/bin/python -m ftin train --model ftin --data $out/train --val $out/val --out $out/ftin --name ftin-sim \
  --window 100 --stride 10 --batch-size 128 --lr 1e-3 --max-minutes "$minutes" \
  --threads 1 --half --seed 0 --no-progress
cp $out/ftin/ftin-sim.safetensors $out/ftin/ftin-sim.json checkpoints/
.venv/bin/python -m ftin evaluate --checkpoint checkpoints/ftin-sim --data $out/val --json $out/val.json
.venv/bin/python -m ftin.train.model_card checkpoints/ftin-sim.json $out/val.json > checkpoints/ftin-sim.md
