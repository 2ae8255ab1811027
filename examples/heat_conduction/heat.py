"""Partitioned heat conduction in 1D, Dirichlet-Neumann, against a manufactured solution, as two preCICE participants
that subcycle.

u(x, t) = 1 + x^2 + beta t solves u_t = u_xx + (beta - 2) on [0, 2]; the Dirichlet participant holds [0, 1], the
Neumann participant [1, 2], cut at x = 1. Both use central differences (exact for a quadratic in x) and implicit
Euler (exact for a linear function of t), so each would reproduce u to round-off given the exact interface data:
the coupled error is the coupling's alone. The Dirichlet side reads the interface temperature and writes the heat
flux u_x(1) (a one-sided second-order difference); the Neumann side reads the flux (a ghost node) and writes the
temperature. The temperature varies linearly in time inside a window, so with substeps and waveform degree 1 a
participant reads it exactly at each of its steps; at degree 0 it reads the window's end value.

    python3 heat.py Dirichlet ../precice-config.xml --substeps 3 --out dirichlet.txt
"""

import argparse

import numpy as np
import precice

BETA, NODES = 1.3, 11            # nodes per side, the interface included


def exact(x: np.ndarray, t: float) -> np.ndarray:
    return 1.0 + x ** 2 + BETA * t


def step(u: np.ndarray, h: float, dx: float, left: tuple[str, float], right: tuple[str, float]) -> np.ndarray:
    """One implicit Euler step of u_t = u_xx + beta - 2; each end ("value", u) or ("flux", u_x) at the step's end."""
    n = len(u)
    matrix = np.zeros((n, n))
    rhs = u + h * (BETA - 2.0)
    r = h / dx ** 2
    for i in range(1, n - 1):
        matrix[i, i - 1:i + 2] = [-r, 1 + 2 * r, -r]
    for index, inner, sign, (kind, value) in ((0, 1, -1.0, left), (n - 1, n - 2, 1.0, right)):
        if kind == "value":
            matrix[index, index], rhs[index] = 1.0, value
        else:           # a ghost node at index - sign: u_ghost = u_inner + sign 2 dx u_x
            matrix[index, index], matrix[index, inner] = 1 + 2 * r, -2 * r
            rhs[index] += sign * 2 * r * dx * value
    return np.linalg.solve(matrix, rhs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("side", choices=("Dirichlet", "Neumann"))
    parser.add_argument("config")
    parser.add_argument("--substeps", type=int, default=3)
    parser.add_argument("--out", default="error.txt")
    args = parser.parse_args()
    dirichlet = args.side == "Dirichlet"
    x = np.linspace(0.0, 1.0, NODES) if dirichlet else np.linspace(1.0, 2.0, NODES)
    dx = x[1] - x[0]
    mesh = f"{args.side}-Mesh"
    write, read = ("Heat-Flux", "Temperature") if dirichlet else ("Temperature", "Heat-Flux")

    participant = precice.Participant(args.side, args.config, 0, 1)
    vertex = participant.set_mesh_vertices(mesh, np.array([[1.0, 0.0]]))
    u, t = exact(x, 0.0), 0.0

    def written(u: np.ndarray) -> np.ndarray:
        if dirichlet:       # the flux at x = 1, second order one-sided
            return np.array([(3 * u[-1] - 4 * u[-2] + u[-3]) / (2 * dx)])
        return np.array([u[0]])

    if participant.requires_initial_data():
        participant.write_data(mesh, write, vertex, written(u))
    participant.initialize()
    h = participant.get_max_time_step_size() / args.substeps
    errors = []
    while participant.is_coupling_ongoing():
        if participant.requires_writing_checkpoint():
            saved = (t, u.copy())
        dt = min(h, participant.get_max_time_step_size())
        interface = float(participant.read_data(mesh, read, vertex, dt)[0])
        if dirichlet:
            u = step(u, dt, dx, ("value", float(exact(x[:1], t + dt)[0])), ("value", interface))
        else:
            u = step(u, dt, dx, ("flux", interface), ("value", float(exact(x[-1:], t + dt)[0])))
        participant.write_data(mesh, write, vertex, written(u))
        participant.advance(dt)
        t += dt
        if participant.requires_reading_checkpoint():
            t, u = saved
        elif participant.is_time_window_complete():
            errors.append((t, float(np.abs(u - exact(x, t)).max())))
    participant.finalize()
    np.savetxt(args.out, np.array(errors), header="t max|u - u_exact|")


if __name__ == "__main__":
    main()
