"""One mass of the two-mass oscillator: its constants and its two integrators, shared by the preCICE participant
(``mass.py``) and the cosim component (``mass_component.py``).

Two masses m on springs k to the walls are joined by a spring k12, cut at its middle: each mass feels the other
through k12 u_other(t), which it reads from the coupling where its integrator needs it (``neighbour(s)``, s the time
from the step's start).
"""

import numpy as np

MASS, K_WALL, K_MIDDLE = 1.0, 4.0 * np.pi ** 2, 16.0 * np.pi ** 2
START = {"Left": 1.0, "Right": 0.0}       # displacements at t = 0, both at rest


def acceleration(u, other):
    return (K_MIDDLE * other - (K_WALL + K_MIDDLE) * u) / MASS


def newmark(u, v, a, h, neighbour):
    """Newmark's average acceleration (beta 1/4, gamma 1/2): implicit, the neighbour at the step's end."""
    stiffness = K_WALL + K_MIDDLE
    force = K_MIDDLE * neighbour(h)
    u_new = (u + h * v + h * h / 4.0 * (a + force / MASS)) / (1.0 + h * h * stiffness / (4.0 * MASS))
    a_new = (force - stiffness * u_new) / MASS
    return u_new, v + h / 2.0 * (a + a_new), a_new


def rk4(u, v, a, h, neighbour):
    """The classical Runge-Kutta method: the neighbour at the step's start, middle and end."""
    def rate(s, u, v):
        return v, acceleration(u, neighbour(s))
    k1 = rate(0.0, u, v)
    k2 = rate(h / 2, u + h / 2 * k1[0], v + h / 2 * k1[1])
    k3 = rate(h / 2, u + h / 2 * k2[0], v + h / 2 * k2[1])
    k4 = rate(h, u + h * k3[0], v + h * k3[1])
    u_new = u + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
    v_new = v + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    return u_new, v_new, acceleration(u_new, neighbour(h))


INTEGRATORS = {"newmark": newmark, "rk4": rk4}
