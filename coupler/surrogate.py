"""The coupled interface surrogate: learnt online from a run's own calls, used only to accelerate it.

An implicit serial scheme iterates on x (the second participant's output, the first's input):
y = first(x), x~ = second(y), the fixed point x = H(x) = second(first(x)). One participant is
quasi-static (its output a function of its input alone: the solid); the other is dynamic (the
fluid, whose output also depends on its history). The surrogate pairs

- a model of the static participant, fitted on all its calls so far (every sub-iteration): a
  ``cosim.surrogate_models`` plug-in (the solid ROM) with its derivative in closed form;
- a linear model of the dynamic participant's response to its interface input within a window,
  J_D = dOut dIn^+, from the differences between the sub-iterations of the last ``memory``
  windows (within a window its history is fixed, so these secant pairs see the interface
  response alone) and of the current window; and its "free response", the output it would give
  were its input frozen at the last window's, b0_j = b_j - J_D (a_j - a_(j-1)), extrapolated
  in time.

It gives the Jacobian of H (the static block's exact derivative times the dynamic block's secant
model, in either order), which an acceleration takes as its prior (``coupler.accelerations.surrogate``), and
a window's first iterate: the fixed point of the surrogate coupled map, solved by Newton's method.
The full-order participants still answer every call: the surrogate changes where iterations start
and which steps they take, never what a window converges to.

The static model is trained in a background thread from the calls up to the window it starts in,
and taken into use a fixed number of windows later (waiting there if it is not done), so that a run
is reproducible and the coupling does not stop for a training.
"""

from __future__ import annotations

import time
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Protocol

import numpy as np

from cosim.errors import CosimError
from cosim.schema import AnyTable, Positive, Value
from coupler.extrapolation import COEFFICIENTS

MODELS = "cosim.surrogate_models"     # entry points: the static participant's model classes

SETTINGS: dict[str, Any] = {
    "start_window": Value(0, low=0),
    "retrain_every": Positive(10),
    "training_windows": Value(50, low=0),
    "training_lag": Value(2, low=1),
    "static": "",
    "model_type": "rom",
    "model": AnyTable(),
    "memory": Positive(3),
    "rcond": Value(1e-3, low=0.0, high=1.0, low_open=True, high_open=True),
    "free_response_order": Value(1, low=0, high=2),
    "predictor": False,
    "jacobian": True,
}
HELP = {
    "start_window": "the window from which the surrogate is used (0: no surrogate); it is first trained on the "
                    "calls of the windows before it",
    "retrain_every": "the static model is refitted on all calls so far every this many windows",
    "training_windows": "the static model is fitted on the calls of this many last windows (0: all calls so far)",
    "training_lag": "a training started at the end of a window is taken into use this many windows later (the "
                    "coupling goes on meanwhile; it waits there if the training is not done)",
    "static": "the participant whose output is a function of its input alone (the solid), modelled by the ROM "
              "(default: the component with record = true)",
    "model_type": "the static model's plug-in (a cosim.surrogate_models entry point)",
    "model": "the static model's settings (for the ROM: its encoder, regressor and decoder tables)",
    "memory": "the last windows whose sub-iteration differences fit the dynamic participant's response (on the "
              "double flap 3 saved more fluid calls than 5 or 10: the fluid's response drifts with the flow)",
    "rcond": "singular values of the input differences below this fraction of the largest are not inverted",
    "free_response_order": "the extrapolation order of the dynamic participant's free response (the predictor)",
    "predictor": "each window starts from the surrogate coupled map's fixed point (coupling.predictor = "
                 "\"surrogate\"); off by default: it cost iterations on both cases, while the scene's own "
                 "predictor \"acceleration\" takes the surrogate quasi-Newton's step from the last converged iterate",
    "jacobian": "an IQN-ILS acceleration takes the surrogate's Jacobian as its prior (type iqn-surrogate)",
}


class StaticModel(Protocol):
    """A static participant's model: the output for an input, and its derivative."""

    def fit(self, inputs: np.ndarray, outputs: np.ndarray, windows: np.ndarray) -> Any: ...

    def predict(self, f: np.ndarray) -> np.ndarray: ...

    def jacobian(self, f: np.ndarray) -> np.ndarray: ...

    def jacobian_factors(self, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


def load_model_class(name: str) -> Any:
    """The static model's class from its ``cosim.surrogate_models`` entry point."""
    from cosim.registry import entry_points
    available = {e.name: e for e in entry_points(group=MODELS)}
    if name not in available:
        raise KeyError(f"no surrogate model {name!r} is installed (known: {', '.join(sorted(available)) or 'none'})")
    return available[name].load()


class InterfaceSurrogate:
    """The online coupled surrogate of one serial implicit scheme (see the module's description)."""

    def __init__(self, settings: dict[str, Any], static_first: bool, model_factory: Any,
                 predicts_start: bool = False) -> None:
        self.predicts_start = predicts_start    # a window starts from the surrogate's fixed point (the predictor)
        self.first_window = settings["start_window"]
        self.retrain_every = settings["retrain_every"]
        self.lag = settings["training_lag"]
        self.training_windows = settings.get("training_windows", 0)
        self.memory = settings["memory"]
        self.rcond = settings["rcond"]
        self.order = settings["free_response_order"]
        self.static_first = static_first
        self._factory = model_factory
        self.model: StaticModel | None = None
        self._executor: ThreadPoolExecutor | None = None
        self._training: tuple[int, tuple[int, int], Future] | None = None  # (window it is adopted at, calls, the fit)
        self._model_calls = (0, 0)  # the calls the model in use was fitted on: [first, last)
        # the static participant's calls, and each call's window
        self._static_in: list[np.ndarray] = []
        self._static_out: list[np.ndarray] = []
        self._static_window: list[int] = []
        # the dynamic participant's intra-window differences (window, d_in, d_out), and its converged calls
        self._pairs: deque[tuple[int, np.ndarray, np.ndarray]] = deque()
        self._last_dynamic: tuple[np.ndarray, np.ndarray] | None = None
        self._converged: deque[tuple[np.ndarray, np.ndarray]] = deque(maxlen=4)
        self._jd: tuple[np.ndarray, np.ndarray] | None = None   # J_D as factors (out, in): J_D = A @ B
        self.current: tuple[np.ndarray, np.ndarray] | None = None   # the last iterate (x, y)
        self._previous_tilde: np.ndarray | None = None              # and its H(x)
        self.secant_errors: list[float] = []   # |J dx - d H| / |d H| of each secant within a window
        self.window = 0
        # where the time goes, and what the surrogate did
        self.training_seconds = 0.0      # the training thread's CPU time
        self.waiting_seconds = 0.0       # the coupling waiting for a training at its adoption window
        self.call_seconds = 0.0          # predictor and Jacobians, in the coupling's thread
        self.trainings = 0
        self.predictions = 0
        self.rejected_predictions = 0

    # --- what the scheme hands over ------------------------------------------------
    def observe(self, x: np.ndarray, y: np.ndarray, x_tilde: np.ndarray) -> None:
        """One coupling iteration: x went into the first participant, y came out, x~ out of the second."""
        static_in, static_out = (x, y) if self.static_first else (y, x_tilde)
        dynamic = (y, x_tilde) if self.static_first else (x, y)
        self._static_in.append(np.array(static_in, dtype=np.float64))
        self._static_out.append(np.array(static_out, dtype=np.float64))
        self._static_window.append(self.window)
        if self._last_dynamic is not None:
            d_in, d_out = dynamic[0] - self._last_dynamic[0], dynamic[1] - self._last_dynamic[1]
            if np.linalg.norm(d_in) > 0:
                self._pairs.append((self.window, d_in, d_out))
                self._jd = None
        self._last_dynamic = (np.array(dynamic[0]), np.array(dynamic[1]))
        if self.current is not None and self._previous_tilde is not None and self.ready:
            factors = self.jacobian_factors(*self.current)      # the Jacobian at the last iterate, against this secant
            if factors is not None:
                actual = x_tilde - self._previous_tilde
                predicted = factors[0] @ (factors[1] @ (x - self.current[0]))
                self.secant_errors.append(float(np.linalg.norm(predicted - actual)
                                                / max(float(np.linalg.norm(actual)), np.finfo(float).tiny)))
        self.current = (np.array(x), np.array(y))
        self._previous_tilde = np.array(x_tilde)

    def start_window(self) -> None:
        """A window begins: take a finished training into use when its window has come."""
        self.window += 1
        self._last_dynamic = None
        self.current = self._previous_tilde = None
        while self._pairs and self._pairs[0][0] <= self.window - 1 - self.memory:
            self._pairs.popleft()
            self._jd = None
        if self._training is not None and self.window >= self._training[0]:
            started = time.perf_counter()
            try:
                model, seconds = self._training[2].result()
            except Exception as exc:     # the fit's own error, in the training thread
                first, last = self._training[1]
                windows = sorted({self._static_window[first], self._static_window[last - 1]})
                raise CosimError(f"coupling.surrogate: the static model's training on the calls of windows "
                                 f"{' to '.join(map(str, windows))} failed: {exc}") from None
            self.waiting_seconds += time.perf_counter() - started
            self.training_seconds += seconds
            self.model, self._model_calls, self._training = model, self._training[1], None
            self.trainings += 1

    def end_window(self, converged: bool) -> None:
        """The window's last call is the dynamic participant's converged one; trainings start here."""
        dynamic = self._last_dynamic
        if dynamic is not None:
            self._converged.append(dynamic)
        since_first = self.window - max(self.first_window - self.lag, 1)   # the first training is in use at start_window
        if self.first_window and self._training is None and since_first >= 0 and since_first % self.retrain_every == 0:
            self._start_training()

    def attributes(self, acceleration: Any) -> dict[str, float | int]:
        """What the surrogate did and cost, with what the acceleration did with it, for the results file."""
        errors = self.secant_errors
        return {"surrogate_trainings": self.trainings, "surrogate_training_seconds": self.training_seconds,
                "surrogate_waiting_seconds": self.waiting_seconds, "surrogate_call_seconds": self.call_seconds,
                "surrogate_predictions": self.predictions, "surrogate_rejected_predictions": self.rejected_predictions,
                "surrogate_updates": getattr(acceleration, "surrogate_updates", 0),
                "surrogate_fallback_windows": getattr(acceleration, "fallback_windows", 0),
                "surrogate_rejected_steps": getattr(acceleration, "rejected_steps", 0),
                "surrogate_secant_error_median": float(np.median(errors)) if errors else float("nan")}

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None

    # --- training ------------------------------------------------------------------
    def _training_calls(self) -> tuple[int, int]:
        """[first, last) of the calls a training starting now fits on."""
        last = len(self._static_in)
        if not self.training_windows:
            return 0, last
        oldest = self.window - self.training_windows
        return next((i for i, w in enumerate(self._static_window) if w > oldest), last), last

    def _start_training(self, adopt_at: int | None = None, calls: tuple[int, int] | None = None) -> None:
        calls = self._training_calls() if calls is None else calls
        if calls[1] - calls[0] < 3 or len(set(self._static_window[calls[0]:calls[1]])) < 2:
            return          # a model is validated across windows: it waits for the calls of two
        chosen = slice(*calls)
        inputs, outputs = np.array(self._static_in[chosen]), np.array(self._static_out[chosen])
        windows = np.array(self._static_window[chosen])
        factory = self._factory

        def fit() -> tuple[StaticModel, float]:
            started = time.thread_time()      # this thread's CPU time
            model = factory()
            model.fit(inputs, outputs, windows)
            return model, time.thread_time() - started
        if self._executor is None:
            self._executor = ThreadPoolExecutor(1, thread_name_prefix="surrogate-training")
        self._training = (self.window + self.lag if adopt_at is None else adopt_at, calls, self._executor.submit(fit))

    @property
    def ready(self) -> bool:
        """The surrogate is in use from ``start_window`` on, once a model has been trained."""
        return bool(self.first_window) and self.window >= self.first_window and self.model is not None

    # --- the dynamic block -----------------------------------------------------------
    def _dynamic_factors(self) -> tuple[np.ndarray, np.ndarray] | None:
        """J_D = A @ B from the secant pairs, A = dOut V S^-1, B = U^T (truncated SVD of dIn)."""
        if self._jd is None and self._pairs:
            d_in = np.stack([p[1] for p in self._pairs], axis=1)
            d_out = np.stack([p[2] for p in self._pairs], axis=1)
            U, s, Vt = np.linalg.svd(d_in, full_matrices=False)
            keep = s > self.rcond * s[0]
            self._jd = (d_out @ (Vt[keep].T / s[keep]), U[:, keep].T)
        return self._jd

    def jacobian_factors(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """dH/dx at the iterate x (y = first(x)) as U @ G with thin factors: the static block's derivative (its
        own factors) and the dynamic block's secant model, in the scheme's order; None before the surrogate is in
        use."""
        factors = self._dynamic_factors()
        if not self.ready or factors is None:
            return None
        assert self.model is not None
        started = time.perf_counter()
        A, B = factors
        if self.static_first:
            left, right = self.model.jacobian_factors(x)      # J_D J_S(x) = A (B left) right
            U, G = A @ (B @ left), right
        else:
            left, right = self.model.jacobian_factors(y)      # J_S(y) J_D = left (right A) B
            U, G = left, (right @ A) @ B
        self.call_seconds += time.perf_counter() - started
        return U, G

    def jacobian(self, x: np.ndarray, y: np.ndarray) -> np.ndarray | None:
        """dH/dx at the iterate x as a matrix (or None)."""
        factors = self.jacobian_factors(x, y)
        return None if factors is None else factors[0] @ factors[1]

    # --- the predictor -----------------------------------------------------------------
    def predict_start(self, x_last: np.ndarray, plain: np.ndarray | None = None) -> np.ndarray | None:
        """The next window's first iterate: the fixed point of the surrogate coupled map, or None.

        None too when it lies further from the ``plain`` start (the scheme's own prediction) than the last window's
        change of x: a prediction beyond that is the surrogate's error, not the flow's (``rejected_predictions``)."""
        factors = self._dynamic_factors()
        if not self.ready or factors is None or len(self._converged) < 2:
            return None
        assert self.model is not None
        started = time.perf_counter()
        A, B = factors
        history = list(self._converged)[::-1]           # newest first: (a_j, b_j) of the dynamic block
        free = [b - A @ (B @ (a - a_before)) for (a, b), (a_before, _) in zip(history, history[1:])]
        coefficients = COEFFICIENTS[min(self.order, len(free) - 1)]
        b0 = sum(c * v for c, v in zip(coefficients, free))
        a_last = history[0][0]
        x = np.array(x_last, dtype=np.float64)
        scale = max(float(np.linalg.norm(x)), np.finfo(float).tiny)
        model = self.model
        for _ in range(8):                              # Newton on g(x) = H_surrogate(x) - x
            if self.static_first:
                y = model.predict(x)
                g = b0 + A @ (B @ (y - a_last)) - x
                Jg = A @ (B @ model.jacobian(x))
            else:
                y = b0 + A @ (B @ (x - a_last))
                g = model.predict(y) - x
                Jg = (model.jacobian(y) @ A) @ B
            Jg[np.diag_indices_from(Jg)] -= 1.0
            if not np.isfinite(g).all():
                break
            if np.linalg.norm(g) <= 1e-12 * scale:
                break
            x = x - np.linalg.solve(Jg, g)
        self.call_seconds += time.perf_counter() - started
        if not np.isfinite(x).all():
            self.rejected_predictions += 1
            return None
        if plain is not None:
            k = 1 if self.static_first else 0        # x is the dynamic block's output (flap) or its input (tube)
            change = np.linalg.norm(history[0][k] - history[1][k])
            if np.linalg.norm(x - plain) > change:
                self.rejected_predictions += 1
                return None
        self.predictions += 1
        return x

    # --- restart ---------------------------------------------------------------------------
    def checkpoint_state(self) -> dict[str, Any]:
        """The calls and differences the surrogate has seen, its counters, and which calls its model and a pending
        training were fitted on; the models are refitted from those calls on restore (a fit is deterministic)."""
        adopt_at, pending_calls = (self._training[0], self._training[1]) if self._training is not None else (0, (0, 0))
        return {"static_in": np.array(self._static_in), "static_out": np.array(self._static_out),
                "static_window": np.array(self._static_window, dtype=np.int64),
                "pairs_window": np.array([p[0] for p in self._pairs], dtype=np.int64),
                "pairs_in": np.array([p[1] for p in self._pairs]), "pairs_out": np.array([p[2] for p in self._pairs]),
                "converged_in": np.array([c[0] for c in self._converged]),
                "converged_out": np.array([c[1] for c in self._converged]),
                "window": self.window, "model_calls": list(self._model_calls), "adopt_at": adopt_at,
                "pending_calls": list(pending_calls),
                "counters": [self.training_seconds, self.waiting_seconds, self.call_seconds, self.trainings,
                             self.predictions]}

    def restore_checkpoint_state(self, state: dict[str, Any]) -> None:
        """Go on from ``checkpoint_state``: the model in use refitted here, a pending training started again."""
        self._static_in = list(state["static_in"])
        self._static_out = list(state["static_out"])
        self._static_window = [int(w) for w in state["static_window"]]
        self._pairs = deque(zip((int(w) for w in state["pairs_window"]), state["pairs_in"], state["pairs_out"]))
        self._converged = deque(zip(state["converged_in"], state["converged_out"]), maxlen=4)
        self.window = int(state["window"])
        self._jd = None
        first, last = (int(i) for i in state["model_calls"])
        self._model_calls = (first, last)
        if last > first:
            chosen = slice(first, last)
            self.model = self._factory()
            self.model.fit(np.array(self._static_in[chosen]), np.array(self._static_out[chosen]),
                           np.array(self._static_window[chosen]))
        pending = tuple(int(i) for i in state["pending_calls"])
        if pending[1] > pending[0]:
            self._start_training(int(state["adopt_at"]), (pending[0], pending[1]))
        (self.training_seconds, self.waiting_seconds, self.call_seconds, self.trainings,
         self.predictions) = state["counters"]
