"""Reading a run's results.h5 with h5py alone (docs/results.md has the whole layout).

    python examples/read_results/read_results.py runs/fom_mu1

Prints the windows, their coupling iterations, the converged inlet pressure over time, each component's cost per
call and the recorded calls of the solid (a ROM's training set), straight from the HDF5 datasets.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import h5py
import numpy as np


def summary(run: Path) -> dict:
    """What a user reads first from a run's results file."""
    with h5py.File(run / "results.h5", "r") as f:
        time = f["windows/time"][()]                        # the end of each time window [s]
        iterations = f["windows/iterations"][()]            # coupling iterations per window
        pressure = f["fields/pressure"][()]                 # converged value per window, (windows, nodes)
        components = {name: {"calls": len(group["cpu_seconds"]),
                             "median_cpu_us": float(np.median(group["cpu_seconds"][()]) * 1e6),
                             "median_roundtrip_us": float(np.median(group["roundtrip_seconds"][()]) * 1e6)}
                      for name, group in f["components"].items() if "cpu_seconds" in group}
        calls = f["snapshots/solid"] if "snapshots/solid" in f else None
        recorded = {"calls": len(calls["window"]), "converged": int(calls["converged"][()].sum()),
                    "inputs": {k: v.shape for k, v in calls["inputs"].items()}} if calls is not None else {}
        scene = json.loads(f.attrs["scene_resolved"])
    return {"windows": len(time), "end": float(time[-1]), "iterations": int(iterations.sum()),
            "inlet_pressure_max": float(pressure[:, 0].max()), "components": components, "recorded": recorded,
            "dt": scene["time"]["dt"]}


if __name__ == "__main__":
    for key, value in summary(Path(sys.argv[1] if len(sys.argv) > 1 else "runs/fom_mu1")).items():
        print(f"{key}: {value}")
