"""Run a scene: start the components, couple them window by window, store everything.

``run_scene`` owns the whole life of a run: components are started (or reached by
address), described, instantiated and initialised; the scheme advances window by
window while the results file is appended and flushed; on every exit path the
components are shut down and the results file is closed, so that what was computed
before an error stays readable.
"""

from __future__ import annotations

import json
import os
import socket
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

from cosim import stop
from cosim.checkpoint import CheckpointError
from cosim.errors import ComponentError, ComponentTimeout, CosimError, DiskFullError, SceneError
from cosim.launcher import Launcher
from cosim.participant import ParticipantHub, ParticipantProxy
from cosim.proxy import ComponentProxy
from cosim.results_writer import ResultsWriter
from cosim.rundir import RunDirectory
from cosim.scene import BACKEND, Scene
from coupler.accelerations import ACCELERATIONS, make_acceleration
from coupler.accelerations.quasi_newton import IQNILS
from coupler.convergence import make_measure
from coupler.coupled import Coupled
from coupler.linalg import load as load_linalg
from coupler.mapping import MAPPINGS, ScaledMapping, make_mapping
from coupler.preflight import check_parameters
from coupler.recording import CallRecorder
from coupler.restart import read_checkpoint_for, restore_checkpoint, run_identity, write_checkpoint
from coupler.run_log import RunLog
from coupler.run_observers import (
    CouplerLogs,
    PreciceFormatLogs,
    ProgressBar,
    ResultsWindows,
    RunObserver,
    StatusFile,
)
from coupler.scene_rules import check_described, check_precision, coupling_model, resolve_plugins
from coupler.schedule import BackendSchedule
from coupler.schemes import SCHEMES, CouplingScheme, Exchange


@dataclass
class RunSummary:
    out_dir: Path
    windows: int
    iterations: int
    wall_seconds: float                 # elapsed: from the run's start (components' start-up included) to its end
    unconverged: int = 0
    coupling_seconds: float = 0.0       # coupling: from the first window's start to the last one's end
    windows_run: int = 0                # the windows this invocation computed (a resumed run's later ones)

    @property
    def windows_per_second(self) -> float:
        """The coupling's rate: the windows this invocation computed over the coupling time."""
        return self.windows_run / self.coupling_seconds if self.coupling_seconds > 0 else 0.0

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
    start = scene.time.start
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
    try:         # a failure before the run takes the hub leaves no rendezvous file behind
        for b in backends:
            if b.command and hub is not None:
                processes[b.name] = launcher.spawn_command(
                    b.name, b.command, b.cwd, {**component_environment(components[b.participant]), **hub.environment(b.name)},
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
            backend.proxy = ComponentProxy(backend.name, endpoint, process=process, timeout=spec["timeout"], curve=curve,
                                           names=spec["names"], mesh_dimensions=spec["mesh_dimensions"])
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
    except BaseException:
        if hub is not None:
            hub.close()
        raise
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


def link_participants(backends: list[Backend]) -> None:
    """Each preCICE participant that accesses a received mesh directly takes its vertices from the one providing it."""
    providers = {b.participant: b.client for b in backends if isinstance(b.client, ParticipantProxy)}
    for proxy in providers.values():
        proxy.link(providers)


def participants_of(backends: list[Backend]) -> dict[str, Coupled]:
    """Each scene component as the scheme sees it: a proxy, or a schedule of backends."""
    grouped: dict[str, list[Backend]] = {}
    for backend in backends:
        grouped.setdefault(backend.participant, []).append(backend)
    participants: dict[str, Coupled] = {}
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


def build_scheme(scene: Scene, proxies: dict[str, Coupled],
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
                               source.lines_of(data), target.lines_of(data), source.cells_of(data),
                               target.cells_of(data))
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
                          coupling["predictor"], coupling_model(coupling))
    scheme.first_iterate_zero = list(coupling["first_iterate_zero"])
    scheme.initialize()
    scheme.acceleration = make_acceleration(coupling["acceleration"], scheme.block_sizes(scheme.accelerated))
    if scheme.model is not None:
        scheme.acceleration.use_model(scheme.model)
    return scheme


def prepare(scene: Scene) -> int:
    """Everything a run checks before it starts a process: every plug-in's settings filled in (the resolved
    scene), every component's parameters, the run plots, the time grid; returns the number of windows."""
    resolve_plugins(scene)
    check_parameters(scene)
    run_plot_hooks(scene)   # unknown plot names fail before anything starts
    scene.time.check(scene.source)
    return scene.time.windows


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
    prepare(scene)
    with directory:     # the plots are drawn under the lock: no other run may take the directory over meanwhile
        return Run(scene, directory, progress, resume).execute()


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
    from cosim.registry import entry_points
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


class Run:
    """One run of a prepared scene into its directory, step by step: ``start`` (the results file's process, the
    components, the scheme), ``window``, ``checkpoint``, ``stop`` (the components terminated, the results file
    closed) and ``close`` (whatever an error left open). Its observers (``coupler.run_observers``: the results
    file's windows, the logs, the status file, the progress bar) are told of each step."""

    def __init__(self, scene: Scene, directory: RunDirectory, progress: bool, resume: bool = False):
        self.scene, self.directory, self.out_dir = scene, directory, directory.path
        self.time = scene.time
        n_windows = self.n_windows = self.time.windows
        self.identity = run_identity(scene, n_windows)
        self.backends = plan_backends(scene)
        self.saved = read_checkpoint_for(scene, self.out_dir, n_windows, [b.name for b in self.backends]) \
            if resume else None
        # the results file's own process starts first: it is ready by the time the components are
        output = scene["output"]
        self.store = ResultsWriter(self.out_dir / "results.h5", self.out_dir / "logs" / "results.log", scene.text,
                                   (self.saved[0]["results"], self.saved[0]["windows"]) if self.saved else None,
                                   plots=bool(output["run_plot"] or output["plots"]), lock=directory.lock)
        if self.saved is None:
            self.store.set_attributes(scene_resolved=json.dumps(scene.data))
        self.wall_start = time.perf_counter()
        self.wall = 0.0
        self.coupling_start: float | None = None         # the first window's start (perf_counter)
        self.coupling = 0.0
        self.windows_at_start = 0
        self.windows = self.iterations = self.unconverged = self.warned = 0
        if self.saved is not None:
            counts = self.saved[0]
            self.windows, self.iterations, self.unconverged, self.warned = (
                counts["windows"], counts["iterations"], counts["unconverged"], counts["warned"])
        self.every = scene["output"]["checkpoint_every"]
        self.scheme: CouplingScheme | None = None
        self.participants: dict[str, Coupled] | None = None
        self.recorders: dict[str, CallRecorder] = {}
        self.hub: ParticipantHub | None = None
        self.phase = "start-up"   # where an error that is not inside a window happened
        self.log = RunLog(self.out_dir / "logs", self.windows if self.saved is not None else None)
        self.observers: list[RunObserver] = [ResultsWindows(self.store), CouplerLogs(self.log),
                                             PreciceFormatLogs(self.out_dir, self.windows if self.saved is not None
                                                               else None),
                                             StatusFile(directory, n_windows), ProgressBar(progress)]
        self._tell("starting", self)

    def _tell(self, step: str, *args: object) -> None:
        for observer in self.observers:
            getattr(observer, step)(*args)

    def execute(self) -> RunSummary:
        """The whole run: start, every window, stop; on any exit, what was computed is kept."""
        finished = False
        try:
            with self.log, Launcher(self.out_dir / "logs") as launcher:
                try:
                    self.start_components(launcher)
                    self.phase = ""
                    try:
                        for window in range(self.windows, self.n_windows):
                            self.window(window)
                    finally:
                        assert self.scheme is not None
                        self.scheme.run_deferred()
                        self._tell("windows_done", self)
                    self.stop()
                    finished = True
                    self._tell("stopped", self)
                except CosimError as exc:
                    if not exc.where and not isinstance(exc, DiskFullError):
                        exc.where = self.phase or (self.scheme.position() if self.scheme is not None else "")
                    self.windows = min(self.windows, self.store.windows)   # a window the file refused is not done
                    self._tell("failed", self, exc)
                    raise
                except (KeyboardInterrupt, SystemExit):
                    self._tell("interrupted", self)
                    raise
                finally:
                    self.release()
        finally:
            if not finished:
                self.close()
        self._tell("finished", self)
        return RunSummary(self.out_dir, self.windows, self.iterations, self.wall, self.unconverged, self.coupling,
                          windows_run=self.windows - self.windows_at_start)

    def start_components(self, launcher: Launcher) -> None:
        """Start, instantiate and initialise every backend, build the scheme, and write or restore the start."""
        scene, store, backends = self.scene, self.store, self.backends
        components_started = time.perf_counter()
        self.hub = start_backends(scene, backends, launcher,
                                  while_starting=lambda: _import_while_components_start(scene))
        store.ready()
        for b in backends:      # the components build their models at the same time (Kratos reads meshes)
            if isinstance(b.client, ComponentProxy):
                b.client.send_instantiate(b.parameters)
        for b in backends:
            self._tell("event", f"component '{b.name}': {b.entry or b.address or b.command}, pid {b.client.pid}, "
                                f"at {b.client.endpoint}" + (f", log logs/{b.name}.log" if b.entry or b.command else ""))
            host = b.address or socket.gethostname()
            store.add_component(b.name, b.client.pid, host, b.entry or b.address or b.command, b.client.endpoint,
                                participant=b.participant, kind=b.kind, start_time=b.start_time,
                                curve=bool(b.client.curve), **placement(b))
            if isinstance(b.client, ComponentProxy):
                b.client.receive_instantiate()
            else:
                b.client.instantiate(b.parameters)
        link_participants(backends)
        for b in backends:
            if self.saved is None:
                store.write_description(b.name, [asdict(v) for v in b.client.variables.values()], b.client.meshes)
            b.client.enter_initialization_mode(self.time.start, self.time.window_start(self.n_windows))
            b.client.exit_initialization_mode()
        if self.every:
            refusing = [b for b in backends if not b.client.can_checkpoint]
            if refusing:
                raise SceneError(f"{scene.source}: 'output.checkpoint_every' is {self.every}, but component "
                                 f"'{refusing[0].name}' ({refusing[0].entry or refusing[0].address or refusing[0].command}) "
                                 "cannot checkpoint its state")
        self.recorders = {n: CallRecorder(recorded_shapes([b for b in backends if b.participant == n]))
                          for n, s in scene["components"].items() if s["record"]}
        self.participants = participants_of(backends)
        for backend in backends:        # a recorded component that subcycles sends each step's inputs
            if isinstance(backend.client, ComponentProxy):
                backend.client.records_steps = scene["components"][backend.participant]["record"]
        # the scheme knows a participant by its proxy's name (a ROM serving alone: '<name>_rom'); the results file
        # by the scene's
        self.scheme = build_scheme(scene, self.participants,
                                   {self.participants[n].name: r for n, r in self.recorders.items()})
        store.set_attributes(components_startup_seconds=time.perf_counter() - components_started,
                             first_window_started=time.time())
        self.coupling_start, self.windows_at_start = time.perf_counter(), self.windows
        check_plot(scene["output"], self.scheme.values)
        if self.saved is None:
            store.write_initial(self.scheme.values)
        else:
            restore_checkpoint(self.saved, backends, self.scheme)
        self._tell("first_window", self)

    def window(self, window: int) -> None:
        """Window ``window`` (from 0): computed, stored, its bookkeeping deferred into the next one, its warnings
        told, a checkpoint if one is due; a stop asked for ends the run here."""
        scheme = self.scheme
        assert scheme is not None
        window_start = time.perf_counter()
        result = scheme.advance(self.time.window_start(window), self.time.dt)
        self._tell("window_computed", self, result, time.perf_counter() - window_start)
        self.windows += 1
        self.iterations += result.iterations
        done, iterations = self.windows, self.iterations
        scheme.defer(lambda: self._tell("window_reported", self, done, result, iterations))
        for b in self.backends:
            self.warned += len(b.client.warnings)
            for message, count in Counter(b.client.warnings).items():
                calls = f" ({count} calls)" if count > 1 else ""
                self._tell("warning", f"warning: component '{b.name}' in window {done} (t = {result.time - self.time.dt:g} "
                                      f"to {result.time:g}): {message}{calls}")
            b.client.warnings.clear()
        if not result.converged and result.message:
            self.unconverged += 1
            self._tell("warning", f"warning: {result.message}; accepted (coupling.on_max_iterations = \"accept\")")
        # a checkpoint every `every` windows, and when a stop is asked for (even without `every`, if every
        # component can give one): the stopped run can go on with --resume
        stopping = stop.pending() and all(b.client.can_checkpoint for b in self.backends)
        if ((self.every and done % self.every == 0) or stopping) and done < self.n_windows:
            self.checkpoint(result.time)
        if stop.pending():
            scheme.run_deferred()
        stop.check()       # Ctrl-C or SIGTERM: stop here, between two windows

    def checkpoint(self, time_reached: float) -> None:
        """The run's checkpoint after the last window (a stop waits for it)."""
        assert self.scheme is not None
        with stop.deferred():    # a stop waits for the checkpoint it asked for
            try:
                path = write_checkpoint(self.out_dir, self.scheme, self.backends, self.store,
                                        {"windows": self.windows, "iterations": self.iterations,
                                         "unconverged": self.unconverged, "warned": self.warned,
                                         "time": time_reached}, self.identity)
                self._tell("event", f"checkpoint after window {self.windows}: {path.name}, "
                                    f"{path.stat().st_size:,} bytes")
            except CheckpointError as exc:
                raise CheckpointError(f"{exc}; the {self.windows} windows before it are kept in "
                                      f"'{self.out_dir / 'results.h5'}'") from None

    def stop(self) -> None:
        """Every window done: the components terminated (their final outputs stored), the results file closed
        and its plots drawn while the components stop."""
        assert self.scheme is not None
        store = self.store
        store.set_attributes(last_window_ended=time.time())
        self._coupling_ended()
        self.phase = "terminate"
        self.scheme.release_states()
        for b in self.backends:
            final = b.client.terminate()
            if final:
                store.write_final(b.name, final)
        self.phase = "results"
        self.wall = time.perf_counter() - self.wall_start      # the run's, before its plots are drawn
        self._final_attributes()
        output = self.scene["output"]
        store.close(plots={"png": str(self.out_dir / "run.png") if output["run_plot"] else "", "output": output,
                           "folder": str(self.out_dir),
                           "hooks": list(output["plots"])}, wait=False)
        shutdown_proxies([b.proxy for b in self.backends if b.proxy is not None])
        store.wait_closed()

    def release(self) -> None:
        """On every exit: the components asked to stop, the participants' hub and the coupling model closed."""
        shutdown_proxies([b.proxy for b in self.backends if b.proxy is not None])
        if self.hub is not None:
            self.hub.close()
        if self.scheme is not None and self.scheme.model is not None:
            self.scheme.model.close()

    def _coupling_ended(self) -> None:
        if self.coupling_start is not None:
            self.coupling = time.perf_counter() - self.coupling_start

    def close(self) -> None:
        """A run that did not finish: what it knows is kept (an error under way is the one reported)."""
        self.wall = time.perf_counter() - self.wall_start
        if not self.coupling:
            self._coupling_ended()
        try:
            self._final_attributes()
            self.store.close()
        except CosimError:
            self.store.abandon()

    def _final_attributes(self) -> None:
        """The run's closing attributes: its wall time, the windows accepted unconverged, the warnings, the ROM's
        fallback windows, the coupling model's counts."""
        schedules = [p for p in (self.participants or {}).values() if isinstance(p, BackendSchedule)]
        self.store.set_attributes(wall_seconds=self.wall, coupling_seconds=self.coupling,
                                  windows_unconverged=self.unconverged,
                                  component_warnings=self.warned,
                                  rom_fallback_windows=sum(len(p.fallback_windows) for p in schedules))
        if self.scheme is not None and self.scheme.model is not None:
            self.store.set_attributes(**self.scheme.model.attributes(self.scheme.acceleration))


def _import_while_components_start(scene: Scene | None = None) -> None:
    """What the coupler computes with, imported while its components start: the LAPACK of an acceleration that
    factorises (IQN-ILS and its kind; SciPy's import is half a second of CPU the components' start-up would share),
    the window's rows of the results file (not h5py: the results writer's process opens the file), SciPy's KD-tree and sparse matrices where a mapping is built on
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


