"""A coupled run's checkpoint and its restart (``cosim run --resume``).

Every ``output.checkpoint_every`` windows, and when Ctrl-C or SIGTERM stops the run after the window in flight,
the run writes ``checkpoint.npz`` next to ``results.h5`` (``cosim.checkpoint``: JSON and arrays, no pickle):

- each backend's own checkpoint (the ``checkpoint`` call of the component contract);
- the coupling scheme's state: data values, the acceleration's columns or Jacobian, the extrapolation's and the
  predictor's history, the measures, the backend schedules;
- the window counter and the run's counts, and the length of every growing dataset of ``results.h5``.

A resumed run checks that the scene (with its ``--set`` overrides) and the package versions are those the run
started with, cuts ``results.h5`` back to the checkpoint, restores every component and the scheme and goes on: it
is the uninterrupted run, bit for bit, with the timings as the only difference.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from cosim.checkpoint import FILE, CheckpointError, pack, read, unpack, write
from cosim.results import ResultsStore, versions
from cosim.scene import Scene

COMPONENTS = "component:"     # the checkpoint's own prefix of a component's arrays


def write_checkpoint(out_dir: Path, scheme: Any, backends: list, store: ResultsStore,
                     counts: dict[str, Any]) -> Path:
    """Write the run's checkpoint (between windows); its size and write time go to the results' attributes."""
    started = time.perf_counter()
    arrays: dict[str, np.ndarray] = {}
    components = {}
    for backend in backends:
        document, state = backend.client.checkpoint()
        components[backend.name] = document
        arrays.update({f"{COMPONENTS}{backend.name}/{key}": value for key, value in state.items()})
    scheme_document, scheme_arrays = pack(scheme.checkpoint_state(), prefix="scheme/")
    arrays.update(scheme_arrays)
    path = write(out_dir / FILE, {**counts, "results": store.lengths(), "scheme": scheme_document,
                                  "components": components}, arrays)
    seconds = time.perf_counter() - started
    written = int(store.file.attrs.get("checkpoints_written", 0)) + 1
    store.set_attributes(checkpoints_written=written, checkpoint_bytes=path.stat().st_size,
                         checkpoint_seconds_total=float(store.file.attrs.get("checkpoint_seconds_total", 0.0)) + seconds)
    return path


def resumable(out_dir: str | Path) -> bool:
    """Whether the run in ``out_dir`` stopped midway (Ctrl-C, SIGTERM, a killed coupler) after a checkpoint."""
    from cosim.rundir import read_status
    out_dir = Path(out_dir)
    return ((out_dir / FILE).is_file() and (out_dir / "results.h5").is_file()
            and read_status(out_dir).get("state") in ("interrupted", "died"))


def read_checkpoint_for(scene: Scene, out_dir: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The checkpoint of the run in ``out_dir``, checked against ``scene`` and this installation's versions."""
    import h5py
    document, arrays = read(out_dir / FILE)
    try:
        with h5py.File(out_dir / "results.h5", "r") as results:
            text, recorded = str(results.attrs["scene"]), json.loads(results.attrs["versions"])
    except (OSError, KeyError, ValueError) as exc:
        raise CheckpointError(f"'{out_dir / 'results.h5'}' cannot be read to go on with it: {exc}") from None
    if text != scene.text:
        raise CheckpointError(f"'{out_dir}' was run with another scene (or other --set overrides) than "
                              f"'{scene.source}': a run goes on only with the scene it started with")
    current = versions()
    changed = [f"{name} {recorded.get(name)} -> {current.get(name)}" for name in sorted(set(recorded) | set(current))
               if recorded.get(name) != current.get(name)]
    if changed:
        raise CheckpointError(f"'{out_dir}' was run with other versions ({', '.join(changed)}): a resumed run "
                              "would not be the same run")
    return document, arrays


def restore_checkpoint(saved: tuple[dict[str, Any], dict[str, np.ndarray]], backends: list, scheme: Any) -> None:
    """Every backend's state and the scheme's, from ``saved`` (after the components' initialization)."""
    document, arrays = saved
    for backend in backends:
        if backend.name not in document["components"]:
            raise CheckpointError(f"the checkpoint holds no state of component '{backend.name}'")
        prefix = f"{COMPONENTS}{backend.name}/"
        own = {key[len(prefix):]: value for key, value in arrays.items() if key.startswith(prefix)}
        backend.client.restore_checkpoint(document["components"][backend.name], own)
    scheme.restore_checkpoint_state(unpack(document["scheme"], arrays))
