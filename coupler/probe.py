"""``cosim check``'s probe: every component started and instantiated as a run would, with a deadline.

The static checks (``coupler.run.prepare``) know a component's parameters, not its variables: those exist once
the component is instantiated. The probe starts every local component in its own process (logs in a scratch
folder), reaches every component served by hand with a short deadline, instantiates each with the scene's
parameters, checks what the scene asks of them (``coupler.scene_rules.check_described``: the exchanged variables, how
an implicitly coupled participant repeats a window) and stops them. A component served by hand is pinged only:
it serves the first client that drives it, and stops when that client is done, so the probe leaves it to the
run.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from cosim.launcher import Launcher
from cosim.scene import Scene

ADDRESS_DEADLINE = 5.0      # seconds a component served by hand has to answer cosim check


def probe(scene: Scene, windows: int) -> list[str]:
    """Start, instantiate and initialise every component of ``scene`` (over its ``windows``) and check them, then
    stop them; returns a line per backend."""
    from coupler.run import participants_of, plan_backends, shutdown_proxies, start_backends
    from coupler.scene_rules import check_described
    backends = plan_backends(scene)
    programs = [b for b in backends if b.command]       # a participant's program runs the case: left to the run
    backends = [b for b in backends if not b.command]
    with tempfile.TemporaryDirectory(prefix="cosim-check-") as logs, Launcher(Path(logs)) as launcher:
        local = [b for b in backends if b.entry]
        try:
            start_backends(scene, backends, launcher, address_deadline=ADDRESS_DEADLINE)
            for backend in local:
                backend.client.instantiate(backend.parameters)
                backend.client.enter_initialization_mode(scene.time.start, scene.time.window_start(windows))
                backend.client.exit_initialization_mode()
            by_hand = {b.participant for b in backends if not b.entry}
            check_described(scene, participants_of([b for b in local if b.participant not in by_hand]))
            return [f"{b.name}: {', '.join(f'{v.causality} {v.name} {v.shape}' for v in b.client.variables.values())}"
                    if b.entry else f"{b.name}: served by hand at {b.address}, reached (its variables are checked "
                                    "when the run starts)" for b in backends] + \
                [f"{b.name}: the participant '{b.command}' in {b.cwd} (its meshes and data are checked when the run "
                 "starts it)" for b in programs]
        finally:
            shutdown_proxies([b.proxy for b in local if b.proxy is not None])
            for b in backends:
                if not b.entry and b.proxy is not None:
                    b.proxy.close()
