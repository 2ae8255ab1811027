"""Modelica's Reference-FMUs through cosim's FMU importer: each FMU described, and coupled where its variables can be.

Give a folder of the Reference-FMUs, built from their source (they are never part of this project). For each FMU:
what the importer makes of it (its couplable inputs and outputs, or the one-line refusal, and the variables it
keeps to itself with the reason); then a run of one second, windows of 0.1 s, against a component written here
(``Mirror``): an FMU with outputs alone drives it one way, and its values at each window's end are held against
fmpy's own simulation of the FMU (the same communication points); an FMU with a Float64 input gets the mirror's
answer ``1 + t`` back (explicit, both ways).

Usage: python -m scripts.reference_fmus FOLDER [--out DIR]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import Component, Variable
from cosim.errors import CosimError

WINDOW, END = 0.1, 1.0


class Mirror(Component):
    """One scalar in (``signal``, kept), one out (``answer`` = 1 + t at the window's end)."""

    name = "mirror"
    stateless = True

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        self.signal, self.answer = np.zeros(1), np.ones(1)

    def variables(self) -> list[Variable]:
        return [Variable("signal", "input", 1), Variable("answer", "output", 1)]

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        self.signal = np.asarray(values.get("signal", self.signal), dtype=float)

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        return {name: np.array(getattr(self, name)) for name in names}

    def do_step(self, t: float, dt: float) -> None:
        self.answer = np.array([1.0 + t + dt])


SCENE = """
name = "{name} against a mirror"
[time]
end = {end}
dt = {dt}
[components.fmu]
entry = "fmu_component.component:FmuComponent"
parameters = {{ path = "{fmu}" }}
[components.mirror]
entry = "scripts.reference_fmus:Mirror"
names = {{ {output} = "signal"{answer} }}
record = true
[[exchange]]
data = "{output}"
from = "fmu"
to = "mirror"
{back}
[coupling]
scheme = "serial-explicit"
participants = ["fmu", "mirror"]
"""
BACK = """[[exchange]]
data = "{input}"
from = "mirror"
to = "fmu"
"""


def describe(path: Path) -> tuple[dict[str, Variable], dict[str, str], str]:
    """The importer's view: couplable variables, those it keeps to itself (and why), or its refusal."""
    from fmu_component.component import FmuComponent
    component = FmuComponent()
    try:
        component.instantiate({"path": str(path)})
    except CosimError as exc:
        return {}, {}, str(exc)
    return {v.name: v for v in component.variables()}, dict(component.variable_notes), ""


def run(path: Path, out: Path, variables: dict[str, Variable]) -> str:
    """One second against the mirror; the FMU's first scalar Float64 output checked against fmpy's simulation."""
    outputs = [v for v in variables.values() if v.causality == "output" and v.shape == (1,)]
    inputs = [v for v in variables.values() if v.causality == "input" and v.shape == (1,)]
    if not outputs:
        return "no scalar Float64 output to couple"
    output = outputs[0].name
    back = BACK.format(input=inputs[0].name) if inputs else ""
    answer = f', {inputs[0].name} = "answer"' if inputs else ""
    scene = out / f"{path.stem}.toml"
    scene.write_text(SCENE.format(name=path.stem, end=END, dt=WINDOW, fmu=path, output=output, answer=answer,
                                  back=back))
    done = subprocess.run([sys.executable, "-m", "cosim", "run", str(scene), "--out", str(out / path.stem),
                           "--quiet"], capture_output=True, text=True)
    if done.returncode:
        return f"run failed: {done.stderr.strip()}"
    from cosim.results import RunResults
    with RunResults(out / path.stem / "results.h5") as results:
        coupled = np.asarray(results.fields()[output]).ravel()
    if inputs:
        return f"coupled both ways: {len(coupled)} windows, '{output}' at the end {coupled[-1]:.6g}"
    from fmpy import simulate_fmu
    simulated = simulate_fmu(str(path), stop_time=END, output_interval=WINDOW, output=[output])
    theirs = np.interp(WINDOW * np.arange(1, len(coupled) + 1), simulated["time"], simulated[output])
    gap = float(np.max(np.abs(coupled - theirs)))
    return f"drives the mirror: {len(coupled)} windows, largest gap to fmpy's simulation {gap:.2e}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the Reference-FMUs, built")
    parser.add_argument("--out", type=Path, default=None, help="where the runs go (default: a temporary folder)")
    args = parser.parse_args(argv)
    out = args.out or Path(tempfile.mkdtemp(prefix="reference-fmus-"))
    out.mkdir(parents=True, exist_ok=True)
    print("| FMU | couplable (Float64) | kept to itself | coupled |\n| --- | --- | --- | --- |")
    for path in sorted(args.folder.resolve().glob("*.fmu")):
        variables, notes, refused = describe(path)
        if refused:
            print(f"| {path.name} | refused: {refused} | | |")
            continue
        couplable = ", ".join(f"{v.causality} {v.name} {v.shape}" for v in variables.values())
        kept = "; ".join(f"{name}: {why}" for name, why in notes.items())
        print(f"| {path.name} | {couplable or 'none'} | {kept} | {run(path, out, variables)} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
