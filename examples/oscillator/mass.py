"""One mass of the two-mass oscillator, as a preCICE v3 participant that subcycles.

Two masses m on springs k to the walls are joined by a spring k12, cut at its middle (``integrators.py``): the left
mass reads the right one's displacement and writes its own, and the other way round. Each takes ``--substeps`` steps per window with
Newmark's average acceleration (second order) or the classical Runge-Kutta method (fourth order), reading the
neighbour's displacement where its integrator needs it (``read_data`` at a time inside the step). Its converged
state at each window's end goes to ``--out`` (t, u, v per line).

    python3 mass.py Left ../precice-config.xml --integrator rk4 --substeps 4 --out left.txt
"""

import argparse

import numpy as np
import precice
from integrators import INTEGRATORS, START, acceleration


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("side", choices=("Left", "Right"))
    parser.add_argument("config")
    parser.add_argument("--integrator", choices=("newmark", "rk4"), default="newmark")
    parser.add_argument("--substeps", type=int, default=4)
    parser.add_argument("--out", default="trajectory.txt")
    args = parser.parse_args()
    other = "Right" if args.side == "Left" else "Left"
    mesh, write, read = f"Mass-{args.side}-Mesh", f"Displacement-{args.side}", f"Displacement-{other}"
    integrate = INTEGRATORS[args.integrator]

    participant = precice.Participant(f"Mass-{args.side}", args.config, 0, 1)
    vertex = participant.set_mesh_vertices(mesh, np.zeros((1, 2)))
    u, v = START[args.side], 0.0
    if participant.requires_initial_data():
        participant.write_data(mesh, write, vertex, np.array([u]))
    participant.initialize()
    a = acceleration(u, START[other])         # at rest at t = 0: both displacements known
    h = participant.get_max_time_step_size() / args.substeps
    t, trajectory = 0.0, [(0.0, u, v)]
    while participant.is_coupling_ongoing():
        if participant.requires_writing_checkpoint():
            saved = (t, u, v, a)
        step = min(h, participant.get_max_time_step_size())
        u, v, a = integrate(u, v, a, step, lambda s: participant.read_data(mesh, read, vertex, s)[0])
        participant.write_data(mesh, write, vertex, np.array([u]))
        participant.advance(step)
        t += step
        if participant.requires_reading_checkpoint():
            t, u, v, a = saved
        elif participant.is_time_window_complete():
            trajectory.append((t, u, v))
    participant.finalize()
    np.savetxt(args.out, np.array(trajectory), header="t u v")


if __name__ == "__main__":
    main()
