#!/usr/bin/env bash
# The short double-flap protocol of issue 10 (not yet a make target): Re = 250, FOM-FOM over [0, 1.504] s (188 windows of 8 ms; 1.5 s is no multiple of them), train the solid ROM
# on t <= 1.0 s (hold-out over r_f, r_u = 9, quadratic manifold, sparse quadratic regression), ROM-FOM
# from 1.0 to 1.504 s, report. Everything goes to runs/flap_demo/.
# Work in progress (issue 10): the ROM trained on t <= 1.0 s is out of its training range from its first
# window (the inlet ramp ends at 1.0 s) and the coupling stops converging at 1.04 s.
set -euo pipefail
cd "$(dirname "$0")/.."
COSIM=${COSIM:-cosim}
OUT=runs/flap_demo
SCENE=scenes/double_flap.toml
start=$(date +%s.%N)
echo "== FOM-FOM, Re = 250, [0, 1.504] s"
"$COSIM" run "$SCENE" --quiet --overwrite --out $OUT/fom --set time.end=1.504
echo "== cosim train (t <= 1.0 s)"
"$COSIM" train $OUT/fom/results.h5 --config scenes/double_flap_rom.toml --out $OUT/model.npz
echo "== ROM-FOM from 1.0 s"
"$COSIM" run "$SCENE" --quiet --overwrite --out $OUT/rom --set time.end=1.504 \
    --set components.solid.backend=rom --set components.solid.rom.model=$OUT/model.npz \
    --set components.solid.rom.switch_time=1.0
"$COSIM" report $OUT/rom=$OUT/fom --out $OUT/report
echo "flap demo finished in $(python3 -c "import time; print(round(time.time() - $start))") s; see $OUT/report"
