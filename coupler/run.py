"""Run a scene: start the components, couple them window by window, store everything.

``run_scene`` owns the whole life of a run: components are started (or reached by
address), described, instantiated and initialised; the scheme advances window by
window while the results file is appended and flushed; on every exit path the
components are shut down and the results file is closed, so that what was computed
before an error stays readable.
"""

from __future__ import annotations

import json
import math
import os
import socket
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from cosim import stop
from cosim.checkpoint import CheckpointError
from cosim.component import undeclared_state_message
from cosim.errors import ComponentError, ComponentTimeout, CosimError, DiskFullError, SceneError
from cosim.launcher import Launcher
from cosim.participant import ParticipantHub, ParticipantProxy
from cosim.proxy import ComponentProxy
from cosim.results_writer import ResultsWriter
from cosim.rundir import RunDirectory
from cosim.scene import BACKEND, EXPLICIT, Scene
from coupler.accelerations import ACCELERATIONS, make_acceleration
from coupler.accelerations.quasi_newton import IQNILS
from coupler.convergence import make_measure
from coupler.linalg import load as load_linalg
from coupler.mapping import MAPPINGS, ScaledMapping, make_mapping
from coupler.plugins import resolve_plugins
from coupler.preflight import check_parameters
from coupler.recording import CallRecorder
from coupler.restart import read_checkpoint_for, restore_checkpoint, run_identity, write_checkpoint
from coupler.run_log import RunLog
from coupler.schedule import BackendSchedule
from coupler.schemes import SCHEMES, CouplingScheme, Exchange, Participant, WindowResult
from coupler.surrogate import InterfaceSurrogate, load_model_class


@dataclass
class RunSummary:
    out_dir: Path
    windows: int
    iterations: int
    wall_seconds: float
    unconverged: int = 0

    @property
    def mean_iterations(self) -> float:
        return self.iterations / max(self.windows, 1)


@dataclass
class Backend:
    """One component process (or address) serving a scene component from ``start_time`` on."""

    participant: str
    name: str
    kind: str            # "fom", "rom" or "fmu"
    entry: str
    address: str
    parameters: dict
    start_time: float
    proxy: ComponentProxy | ParticipantProxy | None = None     # once started
    command: str = ""       # a participant: the program that calls the coupler, and its folder
    cwd: str = ""
    rendezvous: str = ""    # a participant started by hand: where it finds the coupler

    @property
    def client(self) -> ComponentProxy | ParticipantProxy:
        """The started backend's proxy."""
        if self.proxy is None:
            raise RuntimeError(f"backend '{self.name}' has not been started")
        return self.proxy


def plan_backends(scene: Scene) -> list[Backend]:
    """The processes the scene's schedule needs: the ROM alone if it serves from the start."""
    start = scene["time"]["start"]
    backends = []
    for name, spec in scene["components"].items():
        fom = Backend(name, name, "fom", spec["entry"], spec["address"], scene.component_parameters(name), start,
                      command=spec["command"], cwd=spec["cwd"] or str(scene.folder), rendezvous=spec["rendezvous"])
        if spec["backend"] == "fom":
            backends.append(fom)
            continue
        table = spec[spec["backend"]]
        switch = table["switch_time"]
        fallback = table.get("on_out_of_range") == "fallback"
        if switch > start + 1e-9 * max(1.0, abs(start)) or fallback:
            backends.append(fom)
        parameters = {k: v for k, v in table.items() if k not in BACKEND}
        backends.append(Backend(name, f"{name}_{spec['backend']}", spec["backend"], table["entry"], "",
                                parameters, max(switch, start)))
    return backends


def start_backends(scene: Scene, backends: list[Backend], launcher: Launcher,
                   address_deadline: float | None = None, while_starting: Callable[[], object] | None = None
                   ) -> ParticipantHub | None:
    """Spawn every local backend first (they start in parallel; meanwhile ``while_starting`` runs), then handshake
    each; a component served by hand must answer within its ``startup_timeout`` (or ``address_deadline``). Programs
    that call the coupler (participants) connect to a hub, returned for the caller to close."""
    components = scene["components"]
    processes = {b.name: launcher.spawn(b.name, b.entry, component_environment(components[b.participant]),
                                        components[b.participant]["cores"], [scene.folder])
                 for b in backends if b.entry}
    hub = ParticipantHub() if any(b.command or b.rendezvous for b in backends) else None
    if hub is not None:
        hub.expected = {b.name for b in backends if b.command or b.rendezvous}
    for b in backends:
        if b.command and hub is not None:
            processes[b.name] = launcher.spawn_command(
                b.name, b.command, b.cwd, {**component_environment(components[b.participant]), **hub.environment()},
                components[b.participant]["cores"])
        elif b.rendezvous and hub is not None:
            hub.announce(Path(b.rendezvous))
    if while_starting is not None:
        while_starting()
    for backend in backends:
        spec = scene["components"][backend.participant]
        process = processes.get(backend.name)
        if (backend.command or backend.rendezvous) and hub is not None:
            participant = ParticipantProxy(backend.name, hub, process, timeout=spec["timeout"],
                                           startup_timeout=spec["startup_timeout"])
            backend.proxy = participant
            participant.connect()
            continue
        if process is not None:
            launcher.startup_timeout = spec["startup_timeout"]
            endpoint = launcher.handshake(process)
        else:
            endpoint = backend.address
        curve = spec["curve"] if process is None else ""    # a launched component is on loopback, never CURVE
        backend.proxy = ComponentProxy(backend.name, endpoint, process=process, timeout=spec["timeout"], curve=curve)
        backend.proxy.substep_count = spec["substeps"]
        if process is None:
            deadline = spec["startup_timeout"] if address_deadline is None else address_deadline
            try:
                backend.client.pid = int(backend.client.call("ping", timeout=deadline)[0]["pid"])
            except ComponentTimeout:
                keys = (f"and that '{curve}' holds this client's key and the server's public key" if curve else
                        f"and whether it serves with --curve (then set components.{backend.participant}.curve)")
                raise ComponentError(backend.name, f"no reply from {endpoint} within {deadline:g} s: check that "
                                     f"`cosim serve` runs there and serves this component, that the address is the "
                                     f"one it printed, {keys}") from None
    return hub


def placement(backend: Backend) -> dict[str, list[int]]:
    """The cores a local backend's process may run on (as the run started), for the results file."""
    if not backend.entry or not hasattr(os, "sched_getaffinity"):
        return {}
    try:
        return {"cores": sorted(os.sched_getaffinity(backend.client.pid or 0))}
    except ProcessLookupError:
        return {}


def recorded_shapes(backends: list[Backend]) -> dict[str, dict[str, tuple[int, ...]]]:
    """Shapes of every input and output (locals included) any backend of one participant declares."""
    shapes: dict[str, dict[str, tuple[int, ...]]] = {"inputs": {}, "outputs": {}}
    for backend in backends:
        for variable in backend.client.variables.values():
            if variable.causality in ("input", "output", "local"):
                shapes["inputs" if variable.causality == "input" else "outputs"].setdefault(variable.name, variable.shape)
    return shapes


def component_environment(spec: dict) -> dict[str, str]:
    """Environment of a component's process: its thread count (default one) and any extra variables."""
    threads = str(spec["threads"])
    environment = {name: threads for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}
    environment.update({str(k): str(v) for k, v in spec["environment"].items()})
    return environment


def participants_of(backends: list[Backend]) -> dict[str, Participant]:
    """Each scene component as the scheme sees it: a proxy, or a schedule of backends."""
    grouped: dict[str, list[Backend]] = {}
    for backend in backends:
        grouped.setdefault(backend.participant, []).append(backend)
    participants: dict[str, Participant] = {}
    for name, group in grouped.items():
        if len(group) == 1:
            participants[name] = group[0].client
            continue
        served = [(b.start_time, b.client) for b in group]
        stages = [(start, client) for start, client in served if isinstance(client, ComponentProxy)]
        if len(stages) != len(served):
            raise SceneError(f"components.{name}: a program that calls the coupler (a participant) cannot be "
                             "switched for another backend during a run; swap it for the whole run instead")
        fallback = next((client for (_, client), b in zip(stages, group) if b.kind == "fom"), None) \
            if any(b.parameters.get("on_out_of_range") == "fallback" for b in group) else None
        participants[name] = BackendSchedule(name, stages, fallback)
    return participants


def build_scheme(scene: Scene, proxies: dict[str, Participant],
                 recorders: dict[str, CallRecorder]) -> CouplingScheme:
    """The scene's coupling scheme over described components; checks every exchanged variable."""
    coupling = scene["coupling"]
    check_described(scene, proxies)
    exchanges = []
    for i, spec in enumerate(scene["exchange"]):
        source, target = proxies[spec["from"]], proxies[spec["to"]]
        data = spec["data"]
        out_var, in_var = source.variables[data], target.variables[data]
        mapping = make_mapping(spec["mapping"], source.mesh_of(data), target.mesh_of(data),
                               out_var.shape, in_var.shape, f"exchange.{i} ({data})",
                               source.lines_of(data), target.lines_of(data))
        if spec["scale"] != 1.0:
            mapping = ScaledMapping(mapping, spec["scale"])
        if spec["at_window_end"] and not isinstance(target, ComponentProxy | BackendSchedule):
            raise SceneError(f"exchange.{i}.at_window_end: '{spec['to']}' is a participant, which keeps its data to "
                             "itself; only a component takes the window's last values")
        exchanges.append(Exchange(data, source, target, mapping, spec["waveform_degree"], spec["substeps"],
                                  spec["at_window_end"]))
        if spec["waveform_degree"] > 0 and isinstance(target, ComponentProxy):
            target.reads_waveforms = True
    for proxy in proxies.values():
        if isinstance(proxy, ComponentProxy) and proxy.substep_count > 1:
            proxy.reads_waveforms = True
    participants = [proxies[name] for name in coupling["participants"]]
    measures = [make_measure(m) for m in coupling["convergence"]]
    check_precision(coupling["convergence"], {e.data: e.source.variables[e.data].precision for e in exchanges})
    scheme_class = SCHEMES.classes[coupling["scheme"]]
    scheme = scheme_class(participants, exchanges, measures, None, coupling["acceleration"]["data"],
                          coupling["max_iterations"], coupling["on_max_iterations"],
                          coupling["extrapolation_order"], recorders, coupling["divergence_factor"],
                          coupling["predictor"], make_surrogate(coupling))
    scheme.initialize()
    scheme.acceleration = make_acceleration(coupling["acceleration"], scheme.block_sizes(scheme.accelerated))
    if hasattr(scheme.acceleration, "surrogate"):
        scheme.acceleration.surrogate = scheme.surrogate
    return scheme


def check_described(scene: Scene, proxies: dict[str, Participant]) -> None:
    """What the scene asks of its described components (``proxies``, all or some of them): each exchanged variable
    an output of its sender and an input of its receiver, and, under implicit coupling, a participant that says
    how it repeats a window."""
    for i, spec in enumerate(scene["exchange"]):
        if spec["from"] not in proxies or spec["to"] not in proxies:
            continue          # cosim check: a component served by hand is not described before its run
        source, target = proxies[spec["from"]], proxies[spec["to"]]
        data = spec["data"]
        out_var, in_var = source.variables.get(data), target.variables.get(data)
        if out_var is None or out_var.causality != "output":
            raise SceneError(f"{scene.source}: 'exchange.{i}.data' is '{data}', but component '{spec['from']}' has "
                             f"no output '{data}' (outputs: {', '.join(source.output_names()) or 'none'})")
        if in_var is None or in_var.causality != "input":
            inputs = [v.name for v in target.variables.values() if v.causality == "input"]
            raise SceneError(f"{scene.source}: 'exchange.{i}.data' is '{data}', but component '{spec['to']}' has "
                             f"no input '{data}' (inputs: {', '.join(inputs) or 'none'})")
    if scene["coupling"]["scheme"] in EXPLICIT:
        return
    for name in (n for n in scene["coupling"]["participants"] if n in proxies):
        proxy = proxies[name]
        if not (proxy.can_get_and_set_state or proxy.repeats_steps or proxy.stateless):
            spec = scene["components"][name]
            note = getattr(proxy, "state_note", "")
            raise SceneError(f"{scene.source}: components.{name}: " + (
                f"coupled implicitly, which repeats each window until it converges, but {note}" if note
                else undeclared_state_message(name, spec["entry"] or spec["address"])))


def make_surrogate(coupling: dict) -> InterfaceSurrogate | None:
    """The online interface surrogate of a resolved ``coupling`` table, or None without one."""
    settings = coupling["surrogate"]
    if not settings.get("start_window"):
        return None
    model_class, model = load_model_class(settings["model_type"]), settings["model"]   # checked by resolve_plugins
    return InterfaceSurrogate(settings, settings["static"] == coupling["participants"][0], lambda: model_class(model))


def surrogate_attributes(scheme: CouplingScheme) -> dict[str, float | int]:
    """What the online surrogate did and cost, for the results file's attributes."""
    surrogate, acceleration = scheme.surrogate, scheme.acceleration
    errors = surrogate.secant_errors
    return {"surrogate_trainings": surrogate.trainings, "surrogate_training_seconds": surrogate.training_seconds,
            "surrogate_waiting_seconds": surrogate.waiting_seconds, "surrogate_call_seconds": surrogate.call_seconds,
            "surrogate_predictions": surrogate.predictions, "surrogate_rejected_predictions": surrogate.rejected_predictions,
            "surrogate_updates": getattr(acceleration, "surrogate_updates", 0),
            "surrogate_fallback_windows": getattr(acceleration, "fallback_windows", 0),
            "surrogate_rejected_steps": getattr(acceleration, "rejected_steps", 0),
            "surrogate_secant_error_median": float(np.median(errors)) if errors else float("nan")}


def check_precision(measures: list[dict], precision: dict[str, float]) -> None:
    """Flag, at start, relative limits tighter than the precision the producer declares for the data."""
    def relative_limits(measure: dict, where: str):
        if measure["type"] == "relative":
            yield measure["limit"], where
        for i, member in enumerate(measure.get("measures", [])):
            if measure["type"] == "all-of" or len(measure["measures"]) == 1:
                yield from relative_limits(member, f"{where}.measures.{i}")
    for i, measure in enumerate(measures):
        carried = precision.get(measure["data"], 0.0)
        for limit, where in relative_limits(measure, f"coupling.convergence.{i}"):
            if 0.0 < limit < carried:
                print(f"warning: '{where}' asks for a relative change below {limit:g}, but '{measure['data']}' is "
                      f"computed to {carried:g} only: the window may stall; a residual-relative measure suits "
                      "such data", file=sys.stderr)


def prepare(scene: Scene) -> int:
    """Everything a run checks before it starts a process: every plug-in's settings filled in (the resolved
    scene), every component's parameters, the run plots, the time grid; returns the number of windows."""
    resolve_plugins(scene)
    check_parameters(scene)
    run_plot_hooks(scene)   # unknown plot names fail before anything starts
    start, end, dt = scene["time"]["start"], scene["time"]["end"], scene["time"]["dt"]
    n_windows = int(math.floor((end - start) / dt + 0.5))
    if abs(start + n_windows * dt - end) > 1e-9 * max(1.0, abs(end)):
        raise SceneError(f"{scene.source}: time.end - time.start = {end - start:g} is not a multiple of time.dt = {dt:g}")
    return n_windows


def run_scene(scene: Scene, out_dir: str | Path, progress: bool = True, overwrite: bool = False,
              resume: bool = False) -> RunSummary:
    """Run ``scene`` and write ``out_dir/results.h5`` (and a plot); ``out_dir`` must not hold another run. With
    ``resume``, go on with the run in ``out_dir`` from its checkpoint (``output.checkpoint_every``)."""
    directory = RunDirectory(out_dir, overwrite, resume=resume)     # refuses an empty name before it would mean "."
    programs = [name for name, spec in scene["components"].items() if spec["command"] and spec["backend"] == "fom"]
    if resume and programs:
        raise SceneError(f"{scene.source}: --resume is refused: a preCICE participant keeps its state to itself, and "
                         f"{', '.join(programs)} {'is one' if len(programs) == 1 else 'are'}; run the case again "
                         "(--overwrite)")
    out_dir = directory.path
    n_windows = prepare(scene)
    start, dt = scene["time"]["start"], scene["time"]["dt"]
    with directory:     # the plots are drawn under the lock: no other run may take the directory over meanwhile
        return _run(scene, directory, start, dt, n_windows, progress, resume)


def check_plot(output: dict, values: dict) -> None:
    """``output.plot_index`` must name a value of the plotted field (checked once its size is known)."""
    if not values:
        return
    field = output["plot_field"] or sorted(values)[0]    # the run plot's choice (the results' first field)
    size = values[field].size
    if output["plot_index"] >= size:
        raise SceneError(f"'output.plot_index' is {output['plot_index']}, but '{field}' has {size} values "
                         f"(0 to {size - 1})")


def run_plot_hooks(scene: Scene) -> list:
    """The scene's own run plots (``output.plots``), loaded from the ``cosim.run_plots`` entry points."""
    from importlib.metadata import entry_points
    available = {e.name: e for e in entry_points(group="cosim.run_plots")}
    hooks = []
    for i, name in enumerate(scene["output"]["plots"]):
        if name not in available:
            raise SceneError(f"{scene.source}: 'output.plots.{i}' is {name!r}; known run plots: "
                             f"{', '.join(available) or 'none'}")
        hook = available[name].load()
        for component in getattr(hook, "recorded", ()):   # the recorded calls the plot draws from
            spec = scene["components"].get(component)
            if spec is not None and not spec["record"]:
                raise SceneError(f"{scene.source}: 'output.plots.{i}' ({name!r}) draws from the recorded calls of "
                                 f"'{component}': set components.{component}.record = true, or leave the plot out")
        hooks.append(hook)
    return hooks


def _run(scene: Scene, directory: RunDirectory, start: float, dt: float, n_windows: int,
         progress: bool, resume: bool = False) -> RunSummary:
    out_dir = directory.path
    saved: tuple[dict, dict] | None = None
    identity = run_identity(scene, n_windows)
    backends = plan_backends(scene)
    if resume:
        saved = read_checkpoint_for(scene, out_dir, n_windows, [b.name for b in backends])
    # the results file's own process starts first: it is ready by the time the components are
    store = ResultsWriter(out_dir / "results.h5", out_dir / "logs" / "results.log", scene.text,
                          (saved[0]["results"], saved[0]["windows"]) if saved is not None else None,
                          lock=directory.lock)
    if saved is None:
        store.set_attributes(scene_resolved=json.dumps(scene.data))
    wall_start = time.perf_counter()
    windows = iterations = unconverged = warned = 0
    if saved is not None:
        counts = saved[0]
        windows, iterations, unconverged, warned = (counts["windows"], counts["iterations"], counts["unconverged"],
                                                     counts["warned"])
    every = scene["output"]["checkpoint_every"]
    state = "failed"
    directory.status("starting", force=True, windows_total=n_windows, windows_completed=windows)
    started, windows_at_start = time.time(), windows       # for the rate and the time left (cosim status)
    scheme = None
    participants = None
    hub: ParticipantHub | None = None
    phase = "start-up"   # where an error that is not inside a window happened
    log = RunLog(out_dir / "logs", windows if saved is not None else None)
    log.event(f"{'resumed after window ' + str(windows) if saved is not None else 'started'}: scene "
              f"{scene.source} ({identity['scene_sha256'][:12]}), {n_windows} windows of {dt:g} s from t = {start:g}")
    try:
        with log, Launcher(out_dir / "logs") as launcher:
            try:
                components_started = time.perf_counter()
                hub = start_backends(scene, backends, launcher, while_starting=lambda: _import_while_components_start(scene))
                store.ready()
                for b in backends:      # the components build their models at the same time (Kratos reads meshes)
                    if isinstance(b.client, ComponentProxy):
                        b.client.send_instantiate(b.parameters)
                for b in backends:
                    log.event(f"component '{b.name}': {b.entry or b.address or b.command}, pid {b.client.pid}, at "
                              f"{b.client.endpoint}" + (f", log logs/{b.name}.log" if b.entry or b.command else ""))
                    host = b.address or socket.gethostname()
                    store.add_component(b.name, b.client.pid, host, b.entry or b.address or b.command,
                                        b.client.endpoint,
                                        participant=b.participant, kind=b.kind, start_time=b.start_time,
                                        curve=bool(b.client.curve), **placement(b))
                    if isinstance(b.client, ComponentProxy):
                        b.client.receive_instantiate()
                    else:
                        b.client.instantiate(b.parameters)
                    if saved is None:
                        store.write_description(b.name, [asdict(v) for v in b.client.variables.values()],
                                                b.client.meshes)
                    b.client.enter_initialization_mode(start, start + n_windows * dt)
                    b.client.exit_initialization_mode()
                if every:
                    refusing = [b for b in backends if not b.client.can_checkpoint]
                    if refusing:
                        raise SceneError(f"{scene.source}: 'output.checkpoint_every' is {every}, but component "
                                         f"'{refusing[0].name}' ({refusing[0].entry or refusing[0].address or refusing[0].command}) cannot "
                                         "checkpoint its state")
                recorders = {n: CallRecorder(recorded_shapes([b for b in backends if b.participant == n]))
                             for n, s in scene["components"].items() if s["record"]}
                participants = participants_of(backends)
                for backend in backends:        # a recorded component that subcycles sends each step's inputs
                    if isinstance(backend.client, ComponentProxy):
                        backend.client.records_steps = scene["components"][backend.participant]["record"]
                # the scheme knows a participant by its proxy's name (a ROM serving alone: '<name>_rom'); the
                # results file by the scene's
                scheme = build_scheme(scene, participants, {participants[n].name: r for n, r in recorders.items()})
                store.set_attributes(components_startup_seconds=time.perf_counter() - components_started,
                                     first_window_started=time.time())
                check_plot(scene["output"], scheme.values)
                log.open_tables(scheme.measures)
                measure_names = [m.label() for m in scheme.measures]
                if saved is None:
                    store.write_initial(scheme.values)
                else:
                    restore_checkpoint(saved, backends, scheme)
                bar = _progress(n_windows, progress)
                if bar is not None and windows:
                    bar.update(windows)
                phase = ""
                try:
                    for window in range(windows, n_windows):
                        t = start + window * dt
                        window_start = time.perf_counter()
                        result = scheme.advance(t, dt)
                        store.append_window(
                            result.time, result.iterations, result.converged, time.perf_counter() - window_start,
                            scheme.values, {b.name: _take_timings(b.client) for b in backends},
                            {n: r.take() for n, r in recorders.items()}, result.residuals)
                        windows += 1
                        iterations += result.iterations

                        def bookkeeping(windows: int = windows, result: WindowResult = result,
                                        iterations: int = iterations) -> None:
                            """The window's log rows, the status file and the progress bar: done while the next
                            window's first component computes."""
                            log.window(windows, result, iterations)
                            directory.status("running", windows_total=n_windows, windows_completed=windows,
                                             time=result.time, iterations_total=iterations, started=started,
                                             windows_at_start=windows_at_start, last_iterations=result.iterations,
                                             measures=dict(zip(measure_names, result.measure_history[-1]))
                                             if result.measure_history else {})
                            if bar is not None:
                                bar.update(1)
                                bar.set_postfix_str(_status(result, iterations / windows), refresh=False)

                        scheme.defer(bookkeeping)
                        for b in backends:
                            warned += len(b.client.warnings)
                            for message, count in Counter(b.client.warnings).items():
                                calls = f" ({count} calls)" if count > 1 else ""
                                _warn(f"warning: component '{b.name}' in window {windows} (t = {result.time - dt:g} "
                                      f"to {result.time:g}): {message}{calls}", bar, log)
                            b.client.warnings.clear()
                        if not result.converged and result.message:
                            unconverged += 1
                            _warn(f"warning: {result.message}; accepted (coupling.on_max_iterations = \"accept\")", bar,
                                  log)
                        # a checkpoint every `every` windows, and when a stop is asked for (even without `every`, if
                        # every component can give one): the stopped run can go on with --resume
                        stopping = stop.pending() and all(b.client.can_checkpoint for b in backends)
                        if ((every and windows % every == 0) or stopping) and windows < n_windows:
                            with stop.deferred():    # a stop waits for the checkpoint it asked for
                                try:
                                    path = write_checkpoint(out_dir, scheme, backends, store,
                                                            {"windows": windows, "iterations": iterations,
                                                             "unconverged": unconverged, "warned": warned,
                                                             "time": result.time}, identity)
                                    log.event(f"checkpoint after window {windows}: {path.name}, "
                                              f"{path.stat().st_size:,} bytes")
                                except CheckpointError as exc:
                                    raise CheckpointError(f"{exc}; the {windows} windows before it are kept in "
                                                          f"'{out_dir / 'results.h5'}'") from None
                        if stop.pending():
                            scheme.run_deferred()
                        stop.check()       # Ctrl-C or SIGTERM: stop here, between two windows
                finally:
                    scheme.run_deferred()
                    if bar is not None:
                        bar.close()
                store.set_attributes(last_window_ended=time.time())
                phase = "terminate"
                scheme.release_states()
                for b in backends:
                    final = b.client.terminate()
                    if final:
                        store.write_final(b.name, final)
                phase = "results"
                wall = time.perf_counter() - wall_start      # the run's, before its plots are drawn
                _final_attributes(store, scheme, participants, wall, unconverged, warned)
                # the writer closes the file and draws the plots while the components stop
                store.close(plots={"png": str(out_dir / "run.png"), "output": scene["output"],
                                   "folder": str(out_dir), "hooks": list(scene["output"]["plots"])}, wait=False)
                shutdown_proxies([b.proxy for b in backends if b.proxy is not None])
                store.wait_closed()
                state = "finished"
                log.event(f"finished: {windows} windows, {iterations} coupling iterations "
                          f"(mean {iterations / max(windows, 1):.3f} per window)")
            except CosimError as exc:
                if not exc.where and not isinstance(exc, DiskFullError):
                    exc.where = phase or (scheme.position() if scheme is not None else "")
                windows = min(windows, store.windows)        # a window the results file refused is not done
                directory.status("failed", force=True, windows_total=n_windows, windows_completed=windows,
                                 error=str(exc))
                log.event(f"failed after {windows} windows: {exc}")
                raise
            except (KeyboardInterrupt, SystemExit):
                directory.status("interrupted", force=True, windows_total=n_windows, windows_completed=windows)
                log.event(f"interrupted after {windows} windows")
                raise
            finally:
                shutdown_proxies([b.proxy for b in backends if b.proxy is not None])
                if hub is not None:
                    hub.close()
                if scheme is not None and scheme.surrogate is not None:
                    scheme.surrogate.close()
    finally:
        if state != "finished":      # what a stopped run knows is kept; an error under way is the one reported
            wall = time.perf_counter() - wall_start
            try:
                _final_attributes(store, scheme, participants, wall, unconverged, warned)
                store.close()
            except CosimError:
                store.abandon()
        else:
            directory.status(state, force=True, windows_total=n_windows, windows_completed=windows,
                             windows_unconverged=unconverged, wall_seconds=wall, iterations_total=iterations,
                             started=started, windows_at_start=windows_at_start,
                             time=start + windows * dt)
    return RunSummary(out_dir, windows, iterations, wall, unconverged)


def _import_while_components_start(scene: Scene | None = None) -> None:
    """What the coupler computes with, imported while its components start: the LAPACK of an acceleration that
    factorises (IQN-ILS and its kind; SciPy's import is half a second of CPU the components' start-up would share),
    the window's rows of the results file (h5py), SciPy's KD-tree and sparse matrices where a mapping is built on
    meshes (their import would otherwise wait until the components are up), and the waveforms' B-splines where a
    scene interpolates in time."""
    if scene is None or issubclass(ACCELERATIONS.get(scene["coupling"]["acceleration"]["type"]), IQNILS):
        load_linalg()
    import cosim.results  # noqa: F401
    if scene is not None and any(MAPPINGS.classes[e["mapping"]["type"]].needs_meshes for e in scene["exchange"]):
        import scipy.sparse  # noqa: F401
        import scipy.spatial  # noqa: F401
    if scene is not None and any(e["waveform_degree"] or e["substeps"] for e in scene["exchange"]):
        import scipy.interpolate  # noqa: F401


def _final_attributes(store: ResultsWriter, scheme: CouplingScheme | None,
                      participants: dict[str, Participant] | None, wall: float, unconverged: int, warned: int) -> None:
    """The run's closing attributes: its wall time, the windows accepted unconverged, the warnings, the ROM's
    fallback windows, the surrogate's counts."""
    fallback = sum(len(p.fallback_windows) for p in (participants or {}).values() if isinstance(p, BackendSchedule))
    store.set_attributes(wall_seconds=wall, windows_unconverged=unconverged, component_warnings=warned,
                         rom_fallback_windows=fallback)
    if scheme is not None and scheme.surrogate is not None:
        store.set_attributes(**surrogate_attributes(scheme))


def _warn(message: str, bar, log: RunLog | None = None) -> None:
    if log is not None:
        log.event(message)
    if bar is not None:
        bar.write(message, file=sys.stderr)
    else:
        print(message, file=sys.stderr)


def _take_timings(proxy: ComponentProxy | ParticipantProxy) -> tuple[list[float], list[float], list[float]]:
    compute, roundtrip, cpu = proxy.compute_seconds, proxy.roundtrip_seconds, proxy.cpu_seconds
    proxy.compute_seconds, proxy.roundtrip_seconds, proxy.cpu_seconds = [], [], []
    return compute, roundtrip, cpu


def shutdown_proxies(proxies: list[ComponentProxy | ParticipantProxy]) -> None:
    """Ask each live component to stop (the launcher kills the rest); a proxy closed already is left alone."""
    for proxy in proxies:
        if proxy.closed:
            continue
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
