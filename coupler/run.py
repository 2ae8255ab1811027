"""Run a scene: start the components, couple them window by window, store everything.

``run_scene`` owns the whole life of a run: components are started (or reached by
address), described, instantiated and initialised; the scheme advances window by
window while the results file is appended and flushed; on every exit path the
components are shut down and the results file is closed, so that what was computed
before an error stays readable.
"""

from __future__ import annotations

import math
import socket
import time
from dataclasses import dataclass
from pathlib import Path

from coupler.acceleration import make_acceleration
from coupler.convergence import ConvergenceMeasure
from coupler.mapping import make_mapping
from coupler.recording import CallRecorder
from coupler.schemes import SCHEMES, CouplingScheme, Exchange
from cosim.errors import ComponentError, CosimError, SceneError
from cosim.launcher import Launcher
from cosim.proxy import ComponentProxy
from cosim.results import ResultsStore
from cosim.scene import Scene


@dataclass
class RunSummary:
    out_dir: Path
    windows: int
    iterations: int
    wall_seconds: float

    @property
    def mean_iterations(self) -> float:
        return self.iterations / max(self.windows, 1)


def start_components(scene: Scene, launcher: Launcher) -> dict[str, ComponentProxy]:
    """Spawn every local component first (they start in parallel), then handshake each."""
    specs = scene["components"]
    processes = {name: launcher.spawn(name, spec["entry"]) for name, spec in specs.items() if spec["entry"]}
    proxies = {}
    for name, spec in specs.items():
        process = processes.get(name)
        if process is not None:
            launcher.startup_timeout = spec["startup_timeout"]
            endpoint = launcher.handshake(process)
        else:
            endpoint = spec["address"]
        proxies[name] = ComponentProxy(name, endpoint, process=process, timeout=spec["timeout"])
        if process is None:
            proxies[name].pid = int(proxies[name].call("ping", timeout=spec["startup_timeout"])[0]["pid"])
    return proxies


def build_scheme(scene: Scene, proxies: dict[str, ComponentProxy],
                 recorders: dict[str, CallRecorder]) -> CouplingScheme:
    """The scene's coupling scheme over described components; checks every exchanged variable."""
    coupling = scene["coupling"]
    exchanges = []
    for i, spec in enumerate(scene["exchange"]):
        source, target = proxies[spec["from"]], proxies[spec["to"]]
        data = spec["data"]
        out_var, in_var = source.variables.get(data), target.variables.get(data)
        if out_var is None or out_var.causality != "output":
            raise SceneError(f"exchange.{i}: component '{source.name}' has no output '{data}' "
                             f"(outputs: {', '.join(source.output_names())})")
        if in_var is None or in_var.causality != "input":
            inputs = [v.name for v in target.variables.values() if v.causality == "input"]
            raise SceneError(f"exchange.{i}: component '{target.name}' has no input '{data}' "
                             f"(inputs: {', '.join(inputs)})")
        try:
            mapping = make_mapping(spec["mapping"], source.coordinates, target.coordinates,
                                   out_var.size, in_var.size, f"exchange.{i} ({data})")
        except ValueError as exc:
            raise SceneError(str(exc)) from None
        exchanges.append(Exchange(data, source, target, mapping))
    participants = [proxies[name] for name in coupling["participants"]]
    measures = [ConvergenceMeasure(m["data"], m["type"], m["limit"]) for m in coupling["convergence"]]
    scheme_class = SCHEMES[coupling["scheme"]]
    scheme = scheme_class(participants, exchanges, measures, None, coupling["acceleration"]["data"],
                          coupling["max_iterations"], coupling["on_max_iterations"],
                          coupling["extrapolation_order"], recorders)
    scheme.initialize()
    scheme.acceleration = make_acceleration(coupling["acceleration"], scheme.block_sizes(scheme.accelerated))
    return scheme


def run_scene(scene: Scene, out_dir: str | Path, progress: bool = True) -> RunSummary:
    """Run ``scene`` and write ``out_dir/results.h5`` (and a plot)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    start, end, dt = scene["time"]["start"], scene["time"]["end"], scene["time"]["dt"]
    n_windows = int(math.floor((end - start) / dt + 0.5))
    if abs(start + n_windows * dt - end) > 1e-9 * max(1.0, abs(end)):
        raise SceneError(f"{scene.source}: time.end - time.start = {end - start:g} is not a multiple of time.dt = {dt:g}")
    store = ResultsStore(out_dir / "results.h5", scene.text)
    wall_start = time.perf_counter()
    windows = iterations = 0
    proxies: dict[str, ComponentProxy] = {}
    try:
        with Launcher(out_dir / "logs") as launcher:
            try:
                proxies = start_components(scene, launcher)
                for name, proxy in proxies.items():
                    spec = scene["components"][name]
                    backend = spec["entry"] or spec["address"]
                    store.add_component(name, proxy.pid, socket.gethostname() if spec["entry"] else spec["address"],
                                        backend, proxy.endpoint)
                    proxy.instantiate(scene.component_parameters(name))
                    proxy.enter_initialization_mode(start, end)
                    proxy.exit_initialization_mode()
                recorders = {n: CallRecorder() for n, s in scene["components"].items() if s["record"]}
                scheme = build_scheme(scene, proxies, recorders)
                bar = _progress(n_windows, progress)
                try:
                    for window in range(n_windows):
                        t = start + window * dt
                        window_start = time.perf_counter()
                        result = scheme.advance(t, dt)
                        store.append_window(
                            result.time, result.iterations, result.converged, time.perf_counter() - window_start,
                            scheme.values, {n: _take_timings(p) for n, p in proxies.items()},
                            {n: r.take() for n, r in recorders.items()})
                        windows += 1
                        iterations += result.iterations
                        if bar is not None:
                            bar.update(1)
                            bar.set_postfix_str(_status(result, iterations / windows), refresh=False)
                finally:
                    if bar is not None:
                        bar.close()
                for name, proxy in proxies.items():
                    final = proxy.terminate()
                    if final:
                        store.write_arrays(f"components/{name}/final", final)
            finally:
                _shutdown(proxies)
    finally:
        wall = time.perf_counter() - wall_start
        store.set_attributes("/", wall_seconds=wall, windows_completed=windows)
        store.close()
    summary = RunSummary(out_dir, windows, iterations, wall)
    from cosim.plots import plot_run
    plot_run(out_dir / "results.h5", out_dir / "run.png", scene["output"])
    return summary


def _take_timings(proxy: ComponentProxy) -> tuple[list[float], list[float]]:
    compute, roundtrip = proxy.compute_seconds, proxy.roundtrip_seconds
    proxy.compute_seconds, proxy.roundtrip_seconds = [], []
    return compute, roundtrip


def _shutdown(proxies: dict[str, ComponentProxy]) -> None:
    """Ask each live component to stop (the launcher kills the rest)."""
    for proxy in proxies.values():
        try:
            if proxy.process is None or proxy.process.poll() is None:
                proxy.shutdown(timeout=2.0)
        except (CosimError, ComponentError):
            pass
        proxy.close()


def _progress(total: int, enabled: bool):
    if not enabled:
        return None
    from tqdm import tqdm
    return tqdm(total=total, unit="win", dynamic_ncols=True, mininterval=0.25)


def _status(result, mean_iterations: float) -> str:
    measures = " ".join(f"{k}={v:.1e}" for k, v in result.measures.items())
    return f"t={result.time:.2f} it={result.iterations} mean={mean_iterations:.2f} {measures}"
