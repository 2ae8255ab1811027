#!/usr/bin/env bash
# The paper's tube protocol end to end (make demo):
#   FOM-FOM mu1 on [0, 120] (the first 18 s are the training run), train the ROM on t <= 18
#   (9 section modes, 3 pressure modes, thin-plate-spline RBF, linear decoder), ROM-FOM mu1 switching
#   at 18 s, FOM-FOM and ROM-FOM (T_i = 0.1 s) for mu2, ROM variants for the error-against-run-time
#   table, the ROM exported as an FMU and run in the solid's place, then the report.
#   Everything goes to runs/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
COSIM=${COSIM:-cosim}
OUT=runs/demo
SCENE=scenes/tube_fom.toml
MU2=(--set inlet.f=0.9 --set inlet.h=4)
start=$(date +%s.%N)

run() { echo "== cosim run $*"; "$COSIM" run "$SCENE" --quiet --overwrite "$@"; }
rom() { local model=$1 switch=$2; shift 2
        run --set components.solid.backend=rom --set "components.solid.rom.model=$model" \
            --set "components.solid.rom.switch_time=$switch" "$@"; }

run --out $OUT/fom_mu1
echo "== cosim train"
"$COSIM" train $OUT/fom_mu1/results.h5 --config rom_configs/tube_rom.toml --out $OUT/model.npz
rom $OUT/model.npz 18 --out $OUT/rom_mu1
run --out $OUT/fom_mu2 "${MU2[@]}"
rom $OUT/model.npz 0.1 --out $OUT/rom_mu2 "${MU2[@]}"

# variants for the error-against-run-time comparison (mu1, switch at 18 s)
variants=()
for spec in "energy:--set selection.choose=energy" "no_smoothing:--set model.regressor.smoothing=0" \
            "rf2_ru5:--set model.encoder.modes=2 --set model.decoder.modes=5" \
            "poly:--set model.regressor=poly"; do
  name=${spec%%:*}; args=${spec#*:}
  # shellcheck disable=SC2086
  "$COSIM" train $OUT/fom_mu1/results.h5 --config rom_configs/tube_rom.toml --out $OUT/variants/$name.npz \
    --set selection.table=false $args > $OUT/variants_$name.log
  rom $OUT/variants/$name.npz 18 --out $OUT/variants/$name
  variants+=("$OUT/variants/$name=$OUT/fom_mu1")
done

# the same ROM as an FMI 2.0 Co-Simulation FMU in the solid's place: bit-identical to rom_mu1
echo "== cosim export-fmu"
"$COSIM" export-fmu $OUT/model.npz --out $OUT/solid_rom.fmu
run --set components.solid.backend=fmu --set components.solid.fmu.path=$OUT/solid_rom.fmu \
    --set components.solid.fmu.switch_time=18 --out $OUT/fmu_mu1

echo "== cosim report"
rm -rf $OUT/report   # a fresh report: no PNG of an earlier one stays behind
"$COSIM" report $OUT/rom_mu1=$OUT/fom_mu1 $OUT/rom_mu2=$OUT/fom_mu2 $OUT/fmu_mu1=$OUT/fom_mu1 "${variants[@]}" \
    --out $OUT/report
printf 'demo finished in %.0f s; see %s/report\n' "$(echo "$(date +%s.%N) - $start" | bc)" "$OUT"
