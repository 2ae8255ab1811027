"""A coupled run's checkpoint and its restart (``cosim run --resume``).

Every ``output.checkpoint_every`` windows, and when Ctrl-C or SIGTERM stops the run after the window in flight,
the run writes ``checkpoint.npz`` next to ``results.h5`` (``cosim.checkpoint``: JSON and arrays, no pickle):

- each backend's own checkpoint (the ``checkpoint`` call of the component contract);
- the coupling scheme's state: data values, the acceleration's columns or Jacobian, the extrapolation's and the
  predictor's history, the measures, the backend schedules;
- the window counter and the run's counts, and the length of every growing dataset of ``results.h5``;
- the run's identity: the digest of its resolved scene, the package versions, the digest of every file the scene
  reads.

A resumed run checks the checkpoint's document, its identity against the scene it is given (with its ``--set``
overrides), the installed versions and the input files as they are now, and ``results.h5`` against the
checkpoint, all before it touches anything. Then it cuts ``results.h5`` back to the checkpoint, restores every
component and the scheme and goes on: it is the uninterrupted run, bit for bit, with the timings (and the counts
of checkpoints written) as the only difference.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.checkpoint import FILE, CheckpointError, array_keys, pack, read, unpack, write
from cosim.results_writer import ResultsWriter
from cosim.scene import Scene
from cosim.versions import versions

COMPONENTS = "component:"     # the checkpoint's own prefix of a component's arrays
SCHEME = "scheme/"


def run_identity(scene: Scene, n_windows: int) -> dict[str, Any]:
    """What makes a run this run: its resolved scene, the versions it runs with, the files it reads."""
    return {"scene_sha256": scene.digest(), "versions": versions(), "windows_total": n_windows,
            "inputs": {key: {"path": str(path), "sha256": file_digest(path)}
                       for key, path in scene.input_files().items()}}


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def write_checkpoint(out_dir: Path, scheme: Any, backends: list, store: ResultsWriter,
                     counts: dict[str, Any], identity: dict[str, Any]) -> Path:
    """Write the run's checkpoint (between windows); its size and write time go to the results' attributes."""
    started = time.perf_counter()
    scheme.release_states()       # no handle of the run before it outlives a component's checkpoint
    arrays: dict[str, np.ndarray] = {}
    components = {}
    digests = {}
    for backend in backends:
        document, state = backend.client.checkpoint()
        components[backend.name] = document
        held = {f"{COMPONENTS}{backend.name}/{key}": value for key, value in state.items()}
        digests[backend.name] = state_digest(document, held)
        arrays.update(held)
    scheme_document, scheme_arrays = pack(scheme.checkpoint_state(), prefix=SCHEME)
    arrays.update(scheme_arrays)
    path = write(out_dir / FILE, {**counts, "run": identity, "results": store.lengths(), "scheme": scheme_document,
                                  "components": components, "digests": digests}, arrays)
    store.set_attributes(checkpoint_bytes=path.stat().st_size)
    store.add_to_attributes(checkpoints_written=1, checkpoint_seconds_total=time.perf_counter() - started)
    return path


def state_digest(document: Any, arrays: Mapping[str, np.ndarray]) -> str:
    """A component's checkpoint (its document and its arrays: names, types, shapes and bytes) as a SHA-256: a blob
    damaged on disk (a solver's own restart file among them) is refused before the solver reads it."""
    digest = hashlib.sha256(json.dumps(document, sort_keys=True).encode())
    for name in sorted(arrays):
        value = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}:{value.dtype.str}:{value.shape}".encode())
        digest.update(value.tobytes())
    return digest.hexdigest()


def check_digests(document: dict[str, Any], arrays: Mapping[str, np.ndarray], path: Path) -> None:
    """Each component's state is what was written (a checkpoint of before the digests has none to check)."""
    digests = document.get("digests") or {}
    if not isinstance(digests, dict) or not all(isinstance(v, str) for v in digests.values()):
        raise CheckpointError(f"checkpoint '{path}': 'digests' is {json.dumps(digests)[:80]}; expected a table of "
                              "SHA-256 strings")
    for name, expected in digests.items():
        prefix = f"{COMPONENTS}{name}/"
        held = {key: value for key, value in arrays.items() if key.startswith(prefix)}
        if state_digest(document["components"].get(name), held) != expected:
            raise CheckpointError(f"checkpoint '{path}': the state of component '{name}' is damaged (its digest "
                                  "differs from the one written with it)")


def resumable(out_dir: str | Path) -> bool:
    """Whether the run in ``out_dir`` stopped midway (Ctrl-C, SIGTERM, a killed coupler) after a checkpoint."""
    from cosim.rundir import read_status
    out_dir = Path(out_dir)
    return ((out_dir / FILE).is_file() and (out_dir / "results.h5").is_file()
            and read_status(out_dir).get("state") in ("interrupted", "died"))


def read_checkpoint_for(scene: Scene, out_dir: Path, n_windows: int,
                        components: list[str]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The checkpoint of the run in ``out_dir``, checked against ``scene`` (its ``components``' backends and
    ``n_windows``), this installation's versions, the scene's input files as they are now and ``results.h5``."""
    path = out_dir / FILE

    def wanted(name: str, document: dict[str, Any]) -> bool:
        if name.startswith(SCHEME):
            return name in array_keys(document.get("scheme"))
        return any(name.startswith(f"{COMPONENTS}{c}/") for c in components)

    document, arrays = read(path, wanted, lambda document: check_document(document, path, n_windows, components))
    check_identity(document["run"], scene, n_windows, f"the checkpoint of '{out_dir}'")
    check_digests(document, arrays, path)
    check_results(out_dir / "results.h5", scene, document)
    return document, arrays


def check_document(document: dict[str, Any], path: Path, n_windows: int, components: list[str]) -> None:
    """Every key of a checkpoint's document is there, of its type and in its range."""
    def fail(key: str, expected: str) -> CheckpointError:
        shown = json.dumps(document.get(key))
        return CheckpointError(f"checkpoint '{path}': '{key}' is {shown[:60]}; expected {expected}")

    def count(key: str, low: int, high: int) -> int:
        value = document.get(key)
        if not isinstance(value, int) or isinstance(value, bool) or not low <= value <= high:
            raise fail(key, f"an integer from {low} to {high}")
        return value

    windows = count("windows", 1, n_windows - 1)
    count("iterations", windows, 2**62)
    count("unconverged", 0, windows)
    count("warned", 0, 2**62)
    if not isinstance(document.get("time"), float) or not math.isfinite(document["time"]):
        raise fail("time", "a finite number")
    results = document.get("results")
    if not isinstance(results, dict) or not results or not all(
            isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in results.values()):
        raise fail("results", "a table of dataset lengths (integers >= 0)")
    if not isinstance(document.get("scheme"), dict) or not document["scheme"]:
        raise fail("scheme", "the scheme's state (a table)")
    held = document.get("components")
    if not isinstance(held, dict) or not all(c in held for c in components):
        raise fail("components", f"a state for each of {', '.join(components)}")
    run = document.get("run")
    if not isinstance(run, dict) or not isinstance(run.get("scene_sha256"), str) \
            or not isinstance(run.get("versions"), dict) or not isinstance(run.get("inputs"), dict):
        raise fail("run", "the run's identity (a checkpoint of this version of cosim)")


def check_identity(identity: dict[str, Any], scene: Scene, n_windows: int, what: str) -> None:
    """``identity`` (a checkpoint's) is the run ``scene`` makes now, with these versions and input files."""
    if identity["scene_sha256"] != scene.digest() or identity.get("windows_total") != n_windows:
        raise CheckpointError(f"{what} was run with another scene (or other --set overrides) than "
                              f"'{scene.source}': a run goes on only with the scene it started with")
    recorded, current = identity["versions"], versions()
    changed = [f"{name} {recorded.get(name)} -> {current.get(name)}" for name in sorted(set(recorded) | set(current))
               if recorded.get(name) != current.get(name)]
    if changed:
        raise CheckpointError(f"{what} was run with other versions ({', '.join(changed)}): a resumed run "
                              "would not be the same run")
    now = scene.input_files()
    for key in sorted(set(identity["inputs"]) | set(now)):
        before = identity["inputs"].get(key, {})
        if key not in now or not isinstance(before, dict) or before.get("sha256") != file_digest(now[key]):
            where = now.get(key, before.get("path") if isinstance(before, dict) else "?")
            raise CheckpointError(f"'{key}' ({where}) is not the file the run started with (its digest differs, "
                                  "or it is gone): a resumed run would mix two inputs; restore the file, or start "
                                  "the run again")


def check_results(results_path: Path, scene: Scene, document: dict[str, Any]) -> None:
    """``results.h5`` is the checkpoint's run and holds at least what the checkpoint counts."""
    import h5py
    try:
        with h5py.File(results_path, "r") as results:
            resolved = json.loads(str(results.attrs["scene_resolved"]))
            recorded = {name: results[name].shape[0] for name in document["results"] if name in results}
    except (OSError, KeyError, ValueError) as exc:
        raise CheckpointError(f"'{results_path}' cannot be read to go on with it: {exc}") from None
    if Scene(resolved, "", scene.source).digest() != scene.digest():
        raise CheckpointError(f"'{results_path}' was run with another scene (or other --set overrides) than "
                              f"'{scene.source}': a run goes on only with the scene it started with")
    for name, length in document["results"].items():
        if recorded.get(name, -1) < length:
            raise CheckpointError(f"'{results_path}': dataset '{name}' holds {recorded.get(name, 0)} rows, fewer "
                                  f"than the checkpoint's {length}: the checkpoint is not of this results file")


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
