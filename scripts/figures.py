"""Regenerate every figure of the README's "Measured" section, and print it with the machine.

Runs the tube demo (scripts/tube_demo.sh: FOM-FOM, training, ROM-FOM, FMU, report), the
tube benchmark (accelerations, the paper's inlet tables replayed against its preCICE run,
per-call costs against the ZeroMQ floor) and the ROM-call benchmark, then rewrites the
README between its figure markers. Usage: python -m scripts.figures [--no-readme]   (make figures)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from benchmarks import rom_call, tube_run
from benchmarks.common import machine

ROOT = Path(__file__).resolve().parent.parent

BEGIN, END = "<!-- figures:begin (scripts/figures.py writes this part) -->", "<!-- figures:end -->"
PAPER_TUBE_ROM_ITERATIONS = "+12 %"   # the paper's tube ROM-FOM over FOM-FOM, accumulated iterations


def run_demo() -> dict:
    cosim = Path(sys.executable).with_name("cosim")
    env = dict(os.environ, COSIM=str(cosim) if cosim.exists() else "cosim")
    subprocess.run(["bash", str(ROOT / "scripts" / "tube_demo.sh")], cwd=ROOT, env=env, check=True,
                   stdout=subprocess.DEVNULL)
    runs = json.loads((ROOT / "runs/demo/report/report.json").read_text())["runs"]
    return {Path(r["run"]).name: r for r in runs}


def table(demo: dict, tube: dict, rom: dict) -> str:
    per_window = lambda r: r["iterations"] / r["windows"]  # noqa: E731
    main, variants, tables = tube["main"], tube["variants"], tube["tables"]
    m1, m2, fmu = demo["rom_mu1"], demo["rom_mu2"], demo["fmu_mu1"]
    calls = rom["calls"]
    call = lambda key: calls[key]  # noqa: E731
    rows = [
        ("coupling iterations per window, the paper's mu1 inlet table replayed (IQN-ILS, scene settings)",
         f"{per_window(tables['mu1']):.3f} ({tables['mu1']['iterations']} in 1200 windows)",
         "preCICE, the paper's run: 3.378 (4054)"),
        ("the same, mu2 inlet table", f"{per_window(tables['mu2']):.3f} ({tables['mu2']['iterations']})",
         "preCICE, the paper's run: 3.21"),
        ("mu1 with our converged Duffing inlet: IQN-ILS / + linear extrapolation / reuse 0 / Aitken",
         " / ".join(f"{per_window(r):.3f}" for r in variants.values()), "(no like-for-like reference)"),
        ("wall time of the 1200-window FOM-FOM run", f"{main['wall']:.1f} s", ""),
        ("ROM-FOM vs FOM-FOM, relative L2 error of the inlet pressure, mu1 on [18, 120] / mu2 on [0.1, 120]",
         f"{m1['monitor_error']:.2e} / {m2['monitor_error']:.2e}", ""),
        ("displacement error e(t), mean over the predicted windows, mu1 / mu2",
         f"{m1['displacement_error']['mean']:.2e} / {m2['displacement_error']['mean']:.2e}", ""),
        ("accumulated coupling iterations, ROM-FOM over FOM-FOM, mu1 / mu2",
         f"{(m1['iterations_ratio'] - 1) * 100:+.1f} % / {(m2['iterations_ratio'] - 1) * 100:+.1f} %",
         f"the paper's tube: about {PAPER_TUBE_ROM_ITERATIONS}"),
        ("FMU backend against the rom backend, mu1 (accumulated iterations, inlet pressure error)",
         f"{fmu['iterations']} vs {m1['iterations']}, {fmu['monitor_error']:.2e} vs {m1['monitor_error']:.2e}",
         "identical if bit-for-bit"),
        ("one tube ROM call in-process, us: fast / reproducible (= FMU) arithmetic",
         f"{call('ROM online path, fast arithmetic (BLAS)').median:.1f} / "
         f"{call('ROM online path, reproducible arithmetic (= the FMU, bit for bit)').median:.1f}",
         f"solid FOM here: {call('solid FOM, exact per-branch root, vectorised (ours)').median:.1f}; "
         f"paper-style FOM (root solve per node): "
         f"{call('solid FOM, paper-style scalar root solve per node (baseline)').median:.0f}"),
        ("FMU ROM call through the fmu component (raw fmi2 calls), us",
         f"{call('FMU ROM through the fmu component (raw fmi2 calls)').median:.1f}",
         f"fmpy setReal/doStep/getReal: {call('FMU ROM through fmpy setReal/doStep/getReal (baseline)').median:.1f}"),
        ("round trip of one solid call over tcp://127.0.0.1, us (compute inside)",
         f"{main['solid']['roundtrip'].median:.0f} ({main['solid']['compute'].median:.0f})",
         f"raw ZeroMQ ping-pong, same run: {tube['floor'].median:.0f}"),
    ]
    lines = [f"Machine: {machine()}. Medians; commands: `make figures` (this table), "
             "`python -m benchmarks.tube_run`, `python -m benchmarks.rom_call`, `make demo`.", "",
             "| what | ours | baseline |", "| --- | --- | --- |"]
    lines += [f"| {what} | {ours} | {baseline} |" for what, ours, baseline in rows]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-readme", action="store_true", help="print the table only")
    args = parser.parse_args()
    demo = run_demo()
    tube = tube_run.main([])
    rom = rom_call.main([])
    text = table(demo, tube, rom)
    print("\n" + text)
    if not args.no_readme:
        readme = ROOT / "README.md"
        content = readme.read_text()
        head, rest = content.split(BEGIN)
        _, tail = rest.split(END)
        readme.write_text(f"{head}{BEGIN}\n{text}\n{END}{tail}")
        print("\nREADME.md updated between its figure markers")


if __name__ == "__main__":
    main()
