#!/usr/bin/env bash
# The ROM with memory of Mok's wall, end to end (make demo-mok-rom):
#   FOM-FOM on [0, 25] s recording every structure call; a step map trained on [0, 12] s; ROM-FOM switching at
#   12 s (the ROM takes the structure's last windows over); the same ROM exported as an FMU and run in its place;
#   then out of the training regime: a step map trained on [0, 25] s at the nominal inflow serving from the start
#   at 0.8 and 1.2 times it, against FOM-FOM runs there. Report: runs/mok_rom_demo/report (report.json).
set -euo pipefail
cd "$(dirname "$0")/.."
COSIM=${COSIM:-cosim}
OUT=runs/mok_rom_demo
SCENE=scenes/mok.toml
start=$(date +%s.%N)

run() { echo "== cosim run $*"; "$COSIM" run "$SCENE" --quiet --overwrite "$@"; }
velocity() { python3 -c "print(repr(0.06067 * $1))"; }

run --out $OUT/fom
echo "== cosim train (t <= 12 s)"
"$COSIM" train $OUT/fom/results.h5 --config rom_configs/mok_rom.toml --out $OUT/model.npz
run --out $OUT/rom --set components.structure.backend=rom --set components.structure.rom.model=$OUT/model.npz \
    --set components.structure.rom.switch_time=12
echo "== cosim export-fmu"
"$COSIM" export-fmu $OUT/model.npz --out $OUT/structure_rom.fmu
run --out $OUT/fmu --set components.structure.backend=fmu --set components.structure.fmu.path=$OUT/structure_rom.fmu \
    --set components.structure.fmu.switch_time=12

echo "== cosim train (t <= 25 s) for other inflows"
"$COSIM" train $OUT/fom/results.h5 --config rom_configs/mok_rom.toml --set snapshots.t_max=25 --out $OUT/model_25s.npz
pairs=()
for factor in 0.8 1.2; do
  v=$(velocity $factor)
  run --out $OUT/fom_v$factor --set flow.reference_velocity="$v"
  run --out $OUT/rom_v$factor --set flow.reference_velocity="$v" --set components.structure.backend=rom \
      --set components.structure.rom.model=$OUT/model_25s.npz
  pairs+=("$OUT/rom_v$factor=$OUT/fom_v$factor")
done

echo "== cosim report"
rm -rf $OUT/report
"$COSIM" report $OUT/rom=$OUT/fom $OUT/fmu=$OUT/fom "${pairs[@]}" --out $OUT/report
"${PYTHON:-python3}" -m scripts.mok_rom_table $OUT/report/report.json ${MOK_ROM_DOCS:+--docs}
printf 'demo finished in %.0f s; see %s/report\n' "$(echo "$(date +%s.%N) - $start" | bc)" "$OUT"
