"""preCICE's iteration and convergence logs, in preCICE's format, in the run directory of an implicit run.

preCICE 3 writes, in each participant's folder, ``precice-<participant>-iterations.log`` (every participant of an
implicit scheme) and ``precice-<participant>-convergence.log`` (the participant that measures: the second of a
two-participant scheme, a multi-coupling's controller). A run here writes the same files, named after the
coupling's participants, into its run directory, so that a preCICE user's scripts read them as they are:

- iterations: ``TimeWindow TotalIterations Iterations Convergence``, and for the measuring participant with a
  quasi-Newton acceleration ``QNColumns DeletedQNColumns DroppedQNColumns`` (the columns held at the window's end,
  those the filter deleted in the window, those dropped in it for ``max_used_iterations`` or the windows reused);
- convergence: ``TimeWindow Iteration`` and a column per measure, ``ResAbs(mesh:data)``, ``ResRel(...)``,
  ``ResDrop(...)`` (residual-relative) or ``ResAbsOrRel(...)`` (which preCICE 3.4.1 fills with 0, and so does this
  log); min-iteration measures have none. ``mesh`` is the mesh the producer writes the data on.

Integers right-aligned in six characters, values as ``%15.8e``, columns two spaces apart, as preCICE writes them.
A resumed run cuts the files back to the checkpoint's window.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, TextIO

from coupler.run_log import cut_table

NAMES = {"absolute": "ResAbs", "relative": "ResRel", "residual-relative": "ResDrop", "any-of": "ResAbsOrRel"}
ZERO = ("any-of",)      # logged as 0, as preCICE logs its absolute-or-relative measure


class PreciceLogs:
    """The iterations logs of the scheme's participants and the convergence log of the one that measures."""

    def __init__(self, folder: Path, participants: list[str], measuring: str, measures: list[Any],
                 meshes: dict[str, str], quasi_newton: bool, resume_after: int | None = None):
        self.measuring = measuring
        self.measures = list(measures)      # the scheme's, in the order of a window's measure history
        self.shown = [i for i, m in enumerate(self.measures) if m.type_name != "min-iterations"]
        self.quasi_newton = quasi_newton
        paths = {name: folder / f"precice-{name}-iterations.log" for name in participants}
        convergence = folder / f"precice-{measuring}-convergence.log"
        if resume_after is not None:
            for path in [*paths.values(), convergence]:
                cut_table(path, resume_after)
        self.files: dict[str, TextIO] = {}
        for name, path in paths.items():
            columns = ["TimeWindow", "TotalIterations", "Iterations", "Convergence"]
            if name == measuring and quasi_newton:
                columns += ["QNColumns", "DeletedQNColumns", "DroppedQNColumns"]
            self.files[name] = _opened(path, columns)
        labels = [f"{NAMES.get(m.type_name, m.type_name)}({meshes.get(m.data, '')}:{m.data})"
                  for m in (self.measures[i] for i in self.shown)]
        self.convergence = _opened(convergence, ["TimeWindow", "Iteration", *labels])

    def window(self, window: int, result: Any, total_iterations: int, columns: tuple[int, int, int]) -> None:
        """A finished window's rows: its iterations in every participant's log, its measures' values at each
        iteration in the measuring one's; ``columns``: the acceleration's held, deleted and dropped columns."""
        row = [window, total_iterations, result.iterations, int(result.converged)]
        for name, stream in self.files.items():
            numbers = row + list(columns) if name == self.measuring and self.quasi_newton else row
            stream.write("  ".join(f"{n:6d}" for n in numbers) + "\n")
            stream.flush()
        for iteration, values in enumerate(result.measure_history, start=1):
            shown = [0.0 if self.measures[i].type_name in ZERO else values[i] for i in self.shown]
            self.convergence.write("  ".join([f"{window:6d}", f"{iteration:6d}", *(f"{v:15.8e}" for v in shown)])
                                   + "\n")
        self.convergence.flush()

    def close(self) -> None:
        for stream in [*self.files.values(), self.convergence]:
            stream.close()


def _opened(path: Path, columns: list[str]) -> TextIO:
    """``path`` opened to append rows, with preCICE's header line if it is new."""
    fresh = not path.is_file() or path.stat().st_size == 0
    stream = open(path, "a")
    if fresh:
        stream.write("".join(f"  {c}" for c in columns) + "\n")
    return stream
