"""Time in the coupling: the waveforms' interpolant, the schemes on samples inside the window, and the two-mass
oscillator's convergence order under waveform iteration."""

import json
import shutil

import numpy as np
import pytest

from coupler.accelerations import Acceleration
from coupler.accelerations.quasi_newton import IQNILS, IQNIMVJ
from coupler.accelerations.relaxation import Aitken
from coupler.convergence import make_measure
from coupler.mapping import make_mapping
from coupler.schemes import Exchange, ParallelImplicit, SerialImplicit
from coupler.waveform import evaluate, knots, resampling
from tests.conftest import ROOT, participant_module

Waveform = participant_module("_waveform").Waveform


# --- the interpolant ----------------------------------------------------------------------------------------------
def basis(t: np.ndarray, k: int, i: int, x: float) -> float:
    """The i-th B-spline of degree k on knots t at x, by the Cox-de Boor recursion (right-closed at the end)."""
    if k == 0:
        last = t[i + 1] == t[-1] and x == t[-1]
        return 1.0 if t[i] <= x < t[i + 1] or (last and t[i] < t[i + 1]) else 0.0
    left = (x - t[i]) / (t[i + k] - t[i]) * basis(t, k - 1, i, x) if t[i + k] > t[i] else 0.0
    right = (t[i + k + 1] - x) / (t[i + k + 1] - t[i + 1]) * basis(t, k - 1, i + 1, x) if t[i + k + 1] > t[i + 1] \
        else 0.0
    return left + right


def direct(times: np.ndarray, samples: np.ndarray, k: int, at: np.ndarray) -> np.ndarray:
    """The interpolating spline built by hand: knots averaged (de Boor), the collocation system solved, the sum of
    coefficients times basis functions."""
    n = len(times)
    t = np.concatenate([[times[0]] * (k + 1), [np.mean(times[j:j + k]) for j in range(1, n - k)],
                        [times[-1]] * (k + 1)])
    collocation = np.array([[basis(t, k, i, s) for i in range(n)] for s in times])
    coefficients = np.linalg.solve(collocation, samples)
    return np.array([[basis(t, k, i, x) for i in range(n)] for x in at]) @ coefficients


@pytest.mark.parametrize("degree", [1, 2, 3])
def test_the_interpolant_is_the_b_spline_through_the_samples_built_by_hand(degree):
    rng = np.random.default_rng(degree)
    times = np.concatenate([[0.0], np.sort(rng.uniform(0.05, 0.95, 4)), [1.0]])
    samples = rng.normal(size=(6, 3))
    at = np.linspace(0.0, 1.0, 41)
    assert np.allclose(evaluate(times, samples, degree, at), direct(times, samples, degree, at), atol=1e-12)
    assert np.array_equal(evaluate(times, samples, degree, times), samples)      # each sample, exactly
    t = knots(times, degree)
    assert len(t) == len(times) + degree + 1 and np.all(np.diff(t) >= 0)


def test_the_interpolant_is_linear_at_degree_1_a_polynomial_through_few_samples_and_the_end_at_degree_0():
    times = np.array([0.0, 0.3, 0.55, 1.0])
    samples = np.array([1.0, -2.0, 0.5, 4.0])
    at = np.linspace(0, 1, 23)
    assert np.allclose(evaluate(times, samples[:, None], 1, at)[:, 0], np.interp(at, times, samples), atol=1e-14)
    cubic = np.polyfit(times, samples, 3)           # four samples: the cubic through them
    assert np.allclose(evaluate(times, samples[:, None], 3, at)[:, 0], np.polyval(cubic, at), atol=1e-12)
    assert np.allclose(evaluate(times[[0, -1]], samples[[0, -1], None], 3, at)[:, 0],     # two samples: a line
                       np.interp(at, times[[0, -1]], samples[[0, -1]]), atol=1e-14)
    assert np.array_equal(evaluate(times, samples[:, None], 0, at)[:, 0], np.full(len(at), 4.0))
    for degree in (1, 2, 3):            # a polynomial of the degree is reproduced
        values = (times - 0.2) ** degree
        assert np.allclose(evaluate(times, values[:, None], degree, at)[:, 0], (at - 0.2) ** degree, atol=1e-12)
    matrix = resampling(times, 2, at)
    assert np.allclose(matrix @ samples, evaluate(times, samples[:, None], 2, at)[:, 0], atol=1e-14)


def test_the_coefficients_from_the_kept_matrix_are_the_splines():
    from coupler.waveform import coefficients, spline
    inner = np.array([0.2, 0.45, 0.7])
    samples = np.random.default_rng(3).normal(size=(5, 4, 2))
    for degree in (1, 2, 3):
        direct_fit = spline(np.concatenate([[0.0], inner, [1.0]]), samples, degree)
        knots_, c = coefficients(inner, samples, degree)
        assert np.array_equal(knots_, direct_fit.t) and np.allclose(c, direct_fit.c, atol=1e-13)
        assert np.array_equal(c[0], samples[0]) and np.array_equal(c[-1], samples[-1])    # the window's ends


def test_a_participant_evaluates_the_spline_the_coupler_sends_as_scipy_does():
    from coupler.waveform import spline
    times = np.array([0.0, 0.2, 0.45, 0.7, 1.0])
    samples = np.stack([np.sin(3 * times), np.cos(times)], axis=1)
    for degree in (1, 2, 3):
        interpolant = spline(times, samples, degree)
        waveform = Waveform(interpolant.t, interpolant.c)
        for x in np.linspace(0, 1, 37):
            assert np.allclose(waveform(x), interpolant(x), atol=1e-14, rtol=0)


@pytest.mark.parametrize("degree", [1, 2, 3])
def test_the_coupler_s_spline_at_many_points_is_its_value_at_each_bit_for_bit(degree):
    """``Spline.at`` (every substep of a window at once, as the coupler records a participant's substeps) gives at
    each point the bits the participant's own waveform evaluates there, knots and the window's ends included, for
    values of any shape."""
    from cosim.subcycling import Spline
    from coupler.waveform import spline
    times = np.array([0.0, 0.2, 0.45, 0.7, 1.0])
    samples = np.stack([np.sin(3 * times), np.cos(times)], axis=1)[:, :, None] * np.arange(1, 4)   # (5, 2, 3)
    interpolant = spline(times, samples, degree)
    curve = Spline(interpolant.t, interpolant.c)
    points = np.concatenate([np.linspace(0, 1, 37), interpolant.t])
    participant = Waveform(interpolant.t, interpolant.c)
    assert curve.at(points).tobytes() == np.stack([participant(x) for x in points]).tobytes()
    assert curve.at(points).shape == (len(points), 2, 3)


# --- the schemes on samples ---------------------------------------------------------------------------------------
class Variable:
    def __init__(self, name, causality, size=1):
        self.name, self.causality, self.shape, self.precision = name, causality, (size,), 0.0


class Program:
    """A participant as the schemes see one, in-process: ``law(t, dt, inputs, waveforms)`` gives its outputs and
    its samples inside the window (times, values) or None."""

    reads_waveforms = True
    can_get_and_set_state = False
    step_saves_state = False
    repeats_steps = True
    backend_changed = False
    substep_calls: list = []
    gradients: dict = {}

    def coupling_state(self):
        return None

    def __init__(self, name, writes, reads, law, initial=0.0):
        self.name, self.law, self.writes = name, law, writes
        self.variables = {writes: Variable(writes, "output"), reads: Variable(reads, "input")}
        self.initial = initial
        self.substeps = None
        self.received = []

    def get_values(self, names):
        return {name: np.array([self.initial]) for name in names}

    def send_step(self, t, dt, inputs, waveforms=None, **_):
        self.received.append((dict(inputs), dict(waveforms or {})))
        outputs, self.substeps = self.law(t, dt, inputs, waveforms or {})
        self._out = outputs

    def receive_step(self):
        return self._out

    def step(self, t, dt, inputs, **options):
        self.send_step(t, dt, inputs, **options)
        return self.receive_step()


def scheme_of(kind, first, second, degree=1, acceleration=None, measures=None):
    identity = make_mapping({"type": "identity"}, np.zeros((1, 2)), np.zeros((1, 2)), (1,), (1,), "test")
    exchanges = [Exchange(first.writes, first, second, identity, degree, True),
                 Exchange(second.writes, second, first, identity, degree, True)]
    measures = measures or [make_measure({"data": second.writes, "type": "absolute", "limit": 1e-12})]
    accelerated = [second.writes] if kind is SerialImplicit else [first.writes, second.writes]
    scheme = kind([first, second], exchanges, measures, acceleration, accelerated, max_iterations=60)
    scheme.initialize()
    if acceleration is not None:
        scheme.acceleration = acceleration
    return scheme


def test_the_measures_look_at_the_window_end_and_the_acceleration_at_every_sample():
    """B's window-end value is fixed and its samples inside the window change with every iteration: the measure,
    on the end, is met at the second iteration; the acceleration saw every sample (three, then the end)."""
    times = np.array([0.25, 0.5, 0.75])
    calls = []

    def law_b(t, dt, inputs, waveforms):
        calls.append(1)
        return {"y": np.array([1.0])}, (times, {"y": np.full((3, 1), float(len(calls)))})

    first = Program("A", "x", "y", lambda t, dt, i, w: ({"x": i["y"] * 0.5}, None))
    second = Program("B", "y", "x", law_b)
    acceleration = Acceleration()       # plain fixed point: the next iterate is H(x), every sample of it
    scheme = scheme_of(SerialImplicit, first, second, acceleration=acceleration)
    result = scheme.advance(0.0, 0.1)
    assert result.iterations == 2 and result.converged
    assert acceleration.x.size == 4 and acceleration.x_tilde[:3].tolist() == [2.0, 2.0, 2.0]
    assert scheme.series["y"][0].tolist() == times.tolist()


def test_a_reader_of_degree_1_gets_the_line_through_start_samples_and_end_on_its_mesh():
    def law_b(t, dt, inputs, waveforms):
        return {"y": np.array([t + dt])}, (np.array([0.5]), {"y": np.array([[t + 0.5 * dt]])})

    first = Program("A", "x", "y", lambda t, dt, i, w: ({"x": np.array([0.0])}, None))
    second = Program("B", "y", "x", law_b, initial=0.0)
    scheme = scheme_of(SerialImplicit, first, second, degree=1, acceleration=None)
    for window in range(3):
        scheme.advance(0.1 * window, 0.1)
    inputs, waveforms = first.received[-1]      # window 3's last iteration: B's samples at 0.2, 0.25 and 0.3
    knots_, coefficients = waveforms["y"]
    reader = Waveform(knots_, coefficients)
    assert np.allclose([reader(s)[0] for s in (0.0, 0.5, 1.0)], [0.2, 0.25, 0.3], atol=1e-15)
    assert inputs["y"][0] == pytest.approx(0.3)


@pytest.mark.parametrize("kind", [SerialImplicit, ParallelImplicit])
@pytest.mark.parametrize("method", ["iqn-ils", "iqn-imvj", "aitken"])
def test_the_accelerations_go_on_when_the_number_of_samples_changes(kind, method):
    """B is a contraction of A's waveform sampled on a grid of 1, 3, 2, 5, ... samples a window: IQN-ILS's columns
    kept from earlier windows are resampled onto each new grid, IQN-IMVJ's Jacobian starts afresh, Aitken's
    relaxation goes on; every window converges."""
    counts = [1, 3, 2, 5, 4, 1, 3]
    window_of = {"n": 0}

    def law_a(t, dt, inputs, waveforms):
        return {"x": 0.3 * inputs["y"] + 1.0}, None

    def law_b(t, dt, inputs, waveforms):
        n = counts[window_of["n"] % len(counts)]
        grid = np.arange(1, n + 1) / (n + 1)
        wave = Waveform(*waveforms["x"]) if "x" in waveforms else (lambda s: inputs["x"])
        samples = np.array([0.5 * wave(s) + np.sin(t + s * dt) for s in grid])
        return {"y": 0.5 * inputs["x"] + np.sin(t + dt)}, (grid, {"y": samples})

    first = Program("A", "x", "y", law_a)
    second = Program("B", "y", "x", law_b)
    acceleration = {"iqn-ils": lambda: IQNILS(0.5, reused_time_windows=3), "iqn-imvj": lambda: IQNIMVJ(0.5),
                    "aitken": lambda: Aitken(0.5)}[method]()
    scheme = scheme_of(kind, first, second, acceleration=acceleration,
                       measures=[make_measure({"data": "y", "type": "absolute", "limit": 1e-10}),
                                 make_measure({"data": "x", "type": "absolute", "limit": 1e-10})])
    for window in range(len(counts)):
        window_of["n"] = window
        result = scheme.advance(0.1 * window, 0.1)
        assert result.converged and result.iterations <= (8 if method != "aitken" else 30), (window, result.iterations)
        assert len(scheme.series["y"][0]) == counts[window]


# --- the two-mass oscillator -----------------------------------------------------------------------------------------
def test_the_oscillator_keeps_its_integrators_order_with_substeps_and_falls_to_first_order_at_degree_0(tmp_path):
    """``scripts.oscillator_order --small``: windows 0.02 and 0.01, 4 substeps, as participants over preCICE's API and
    as cosim components that subcycle."""
    from scripts import oscillator_order
    assert oscillator_order.main(["--out", str(tmp_path), "--small"]) == 0
    results = json.loads((tmp_path / "results.json").read_text())

    def order(via, integrator, degree, substeps=True):
        rows = sorted((r for r in results if (r["via"], r["integrator"], r["degree"], r["substeps"]) ==
                       (via, integrator, degree, substeps)), key=lambda r: r["window"])
        return oscillator_order.fitted_order([r["window"] for r in rows], [r["error"] for r in rows])

    for via in ("participants", "components"):
        assert 0.8 < order(via, "newmark", 0) < 1.4 and 0.8 < order(via, "rk4", 0) < 1.4   # window end: first order
        assert order(via, "newmark", 3) > 1.9 and order(via, "rk4", 3) > 3.7                # the integrator's order
        assert 1.8 < order(via, "rk4", 3, substeps=False) < 2.2      # start and end alone: a line, second order
        newmark = [r for r in results if (r["via"], r["integrator"], r["degree"]) == (via, "newmark", 3)]
        assert max(r["energy_change"] for r in newmark) < 1e-12                            # Newmark keeps energy
    same = {(r["integrator"], r["degree"], r["substeps"], r["window"]): r["error"] for r in results
            if r["via"] == "participants"}
    for r in results:       # the two ways are one coupling: the same errors to round-off
        assert r["error"] == pytest.approx(same[r["integrator"], r["degree"], r["substeps"], r["window"]], rel=1e-6)


# --- bad input: one line, exit 2 -------------------------------------------------------------------------------------
EXAMPLE = ROOT / "examples" / "oscillator"
V2_TUBE = ROOT / "examples" / "precice_tube" / "precice-config-v2.xml"
BAD_CONFIGS = [
    ("a degree of 4", [('name="Displacement-Left" waveform-degree="3"', 'name="Displacement-Left" waveform-degree="4"')],
     "line 5: <data:scalar>: 'waveform-degree' is 4; allowed: 0 to 3"),
    ("substeps on data the acceleration does not hold",
     [("coupling-scheme:serial-implicit>", "coupling-scheme:parallel-implicit>")],
     "<exchange data=\"Displacement-Left\" substeps=\"true\">: the acceleration (line 45) does not hold "
     "'Displacement-Left'"),
    ("substeps that are no flag", [('to="Mass-Right" initialize="true"\n              substeps="true"',
                                    'to="Mass-Right" initialize="true"\n              substeps="often"')],
     "'substeps' is 'often'; allowed: true or false"),
]


@pytest.mark.parametrize("what, changes, message", BAD_CONFIGS, ids=[b[0] for b in BAD_CONFIGS])
def test_a_bad_time_setting_of_a_configuration_is_one_line(tmp_path, capsys, what, changes, message):
    from cosim.cli import main
    shutil.copytree(EXAMPLE, tmp_path / "case", ignore=shutil.ignore_patterns("*.txt", "cosim-run"))
    config = tmp_path / "case" / "precice-config.xml"
    text = config.read_text()
    for old, new in changes:
        assert old in text, what
        text = text.replace(old, new)
    config.write_text(text)
    assert main(["run", str(tmp_path / "case" / "case.toml"), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err and message in err and "precice-config.xml" in err, err


@pytest.mark.parametrize("what, old, new, message", [
    ("substeps in a v2 configuration", 'from="Fluid" to="Solid" initialize="true" />',
     'from="Fluid" to="Solid" initialize="true" substeps="true" />', "substeps is a preCICE v3 attribute"),
    ("a v2 waveform order of 5", '<read-data name="CrossSectionLength" mesh="Fluid-Nodes-Mesh" />',
     '<read-data name="CrossSectionLength" mesh="Fluid-Nodes-Mesh" waveform-order="5" />', "'waveform-order' is 5"),
    ("a v2 waveform order on written data", '<write-data name="Pressure" mesh="Fluid-Nodes-Mesh" />',
     '<write-data name="Pressure" mesh="Fluid-Nodes-Mesh" waveform-order="1" />',
     "'waveform-order' goes on a <read-data>"),
])
def test_a_bad_time_setting_of_a_v2_configuration_is_one_line(tmp_path, capsys, what, old, new, message):
    from cosim.cli import main
    text = V2_TUBE.read_text()
    assert old in text, what
    (tmp_path / "precice-config.xml").write_text(text.replace(old, new))
    assert main(["check", str(tmp_path / "precice-config.xml"), "--static"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err and message in err and "precice-config.xml, line" in err, err


BAD_SCENES = [
    ("a degree of 4", ["exchange.0.waveform_degree=4"], "'exchange.0.waveform_degree' is 4; allowed: [0, 3]"),
    ("a degree that is no integer", ["exchange.0.waveform_degree=1.5"], "exchange.0.waveform_degree"),
    ("no steps a window", ["components.Mass-Left.substeps=0"], "'components.Mass-Left.substeps' is 0"),
    ("substeps on data the acceleration does not hold", ["coupling.scheme=parallel-implicit"],
     "'exchange.0.substeps' is on for 'Displacement-Left', which the acceleration does not hold"),
    ("substeps with a switch of backend", ["components.Mass-Left.backend=rom", "components.Mass-Left.rom.model=m.npz",
                                           "components.Mass-Left.rom.switch_time=0.5"],
     "a component that subcycles is served by one backend from the start"),
]


@pytest.mark.parametrize("what, overrides, message", BAD_SCENES, ids=[b[0] for b in BAD_SCENES])
def test_a_bad_time_setting_of_a_scene_is_one_line(tmp_path, capsys, what, overrides, message):
    from cosim.cli import main
    arguments = [a for item in overrides for a in ("--set", item)]
    assert main(["check", str(EXAMPLE / "scene.toml"), "--static", *arguments]) == 2, what
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err and message in err, err


def test_a_component_reading_outside_its_window_stops_the_run_in_one_line(tmp_path, capsys):
    from cosim.cli import main
    shutil.copytree(EXAMPLE, tmp_path / "case", ignore=shutil.ignore_patterns("*.txt", "cosim-run"))
    component = tmp_path / "case" / "mass_component.py"
    component.write_text(component.read_text().replace("self.input_at(self.read, t + s)",
                                                       "self.input_at(self.read, t + s + 1.0)"))
    code = main(["run", str(tmp_path / "case" / "scene.toml"), "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err, err
    assert "component 'Mass-Left' in window 1 (t = 0 to 0.01), iteration 1: 'step' failed: reads " \
           "'Displacement-Right' at t = 1, outside its window [0, 0.01]" in err, err


# --- heat conduction, Dirichlet-Neumann ----------------------------------------------------------------------------
HEAT = ROOT / "examples" / "heat_conduction"


@pytest.mark.parametrize("degree", [1, 0])
def test_heat_conduction_with_substeps_stays_at_the_convergence_limit_at_degree_1(tmp_path, degree):
    """The sides take 3 and 2 steps a window; the manufactured solution is linear in time, so at degree 1 each reads
    the interface exactly at its steps and the coupled error is the iterations' (limit 1e-10 relative, on values
    of 2 to 3.3): at most 1e-9, where the window-end value (degree 0) is off by beta dt / 3 at the first step."""
    from cosim.scene import load_scene
    from coupler.run import run_scene
    shutil.copytree(HEAT, tmp_path / "case", ignore=shutil.ignore_patterns("*.txt", "cosim-run"))
    config = tmp_path / "case" / "precice-config.xml"
    config.write_text(config.read_text().replace('waveform-degree="1"', f'waveform-degree="{degree}"'))
    run_scene(load_scene(tmp_path / "case" / "case.toml"), tmp_path / "out", progress=False)
    errors = [np.loadtxt(tmp_path / "case" / f"{side}.txt")[:, 1].max() for side in ("dirichlet", "neumann")]
    if degree == 1:
        assert max(errors) < 1e-9, errors
    else:
        assert min(errors) > 1e-4, errors


# --- restart ---------------------------------------------------------------------------------------------------------
def test_a_subcycled_run_with_waveforms_resumes_bit_for_bit(tmp_path, monkeypatch):
    """The oscillator's components (4 steps a window, cubic waveforms, IQN-ILS reusing two windows), stopped after
    window 25 with a checkpoint every 10: the checkpoint holds the window's samples and the acceleration's columns
    on their grid, and the resumed run is the uninterrupted one, bit for bit."""
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from tests.test_restart import identical, stopped_at
    overrides = ["time.end=0.4", "output.checkpoint_every=10",
                 "coupling.acceleration.reused_time_windows=2"]
    run_scene(load_scene(EXAMPLE / "scene.toml", overrides), tmp_path / "whole", progress=False)
    with monkeypatch.context() as patch:
        stopped_at(25, patch)
        with pytest.raises(KeyboardInterrupt):
            run_scene(load_scene(EXAMPLE / "scene.toml", overrides), tmp_path / "cut", progress=False)
    run_scene(load_scene(EXAMPLE / "scene.toml", overrides), tmp_path / "cut", progress=False, resume=True)
    identical(tmp_path / "whole", tmp_path / "cut")


# --- recording ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("way", ["case.toml", "scene.toml"])
def test_every_step_of_a_subcycled_window_is_a_recorded_call(tmp_path, way):
    """Both masses take 4 steps a window (Newmark: each reads the other at its steps' ends, which are the other's
    samples): every iteration is 4 recorded calls, the last one at the window's end with the converged fields, and
    each call's input is the other mass's output of the same step."""
    from cosim.results import RunResults
    from cosim.scene import load_scene
    from coupler.run import run_scene
    shutil.copytree(EXAMPLE, tmp_path / "case", ignore=shutil.ignore_patterns("*.txt", "cosim-run"))
    for name in ("case.toml", "scene.toml"):
        path = tmp_path / "case" / name
        path.write_text(path.read_text().replace("rk4", "newmark"))
    run_scene(load_scene(tmp_path / "case" / way, ["time.end=0.1"]), tmp_path / "out", progress=False)
    with RunResults(tmp_path / "out") as results:
        left, right = results.calls("Mass-Left"), results.calls("Mass-Right")
        fields = results.fields()
        iterations = int(results.windows.iterations.sum())
    assert len(left.window) == len(right.window) == 4 * iterations
    last = np.flatnonzero(left.converged)[3::4]
    assert np.array_equal(left.outputs["Displacement-Left"][last], fields["Displacement-Left"])
    # serial: the right mass reads the left one's steps of the same iteration
    assert np.allclose(right.inputs["Displacement-Left"], left.outputs["Displacement-Left"], rtol=0, atol=1e-14)


# --- the tube's solvers, subcycled ---------------------------------------------------------------------------------
def test_the_tube_subcycled_converges_at_its_fluids_first_order_in_the_step(tmp_path):
    """Windows of 0.1 s, both solvers taking 1, 2 and 4 steps a window with linear waveforms, against the tube run
    with windows of 0.0125 s: the error at the window ends falls with the step as implicit Euler's first order
    (ratios near 2 for a halved step, 3 at the last halving, whose step is twice the reference's)."""
    from cosim.results import RunResults
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from tests.conftest import TUBE_SCENE

    def run(name, overrides):
        run_scene(load_scene(TUBE_SCENE, ["time.end=1.0", *overrides]), tmp_path / name, progress=False)
        with RunResults(tmp_path / name) as results:
            return results.windows.time, results.fields()

    times, reference = run("reference", ["time.dt=0.0125"])
    errors = []
    for steps in (1, 2, 4):
        t, fields = run(f"steps{steps}", ["time.dt=0.1", f"components.fluid.substeps={steps}",
                                          f"components.solid.substeps={steps}", "exchange.0.waveform_degree=1",
                                          "exchange.1.waveform_degree=1", "exchange.0.substeps=true",
                                          "exchange.1.substeps=true"])
        rows = np.searchsorted(times, t - 1e-9)
        errors.append(max(np.abs(fields[k] - reference[k][rows]).max() / np.abs(reference[k]).max() for k in fields))
    assert 1.7 < errors[0] / errors[1] < 2.7 and 2.0 < errors[1] / errors[2] < 3.4, errors


def test_a_rom_trained_on_a_subcycled_run_is_trained_per_step_and_serves_subcycled(tmp_path):
    """The tube's solid takes 2 steps a window (linear waveforms, samples exchanged): its recorded calls are two per
    iteration, each a step's pressure and section; the ROM trained on them serves in its place, subcycled too, and
    follows the full-order run."""
    from cosim.cli import main
    from cosim.results import RunResults
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from rom_component.recorded import recorded_calls
    from tests.conftest import TUBE_SCENE
    subcycled = ["time.end=4.0", "components.solid.substeps=2", "components.solid.record=true",
                 "exchange.0.waveform_degree=1", "exchange.1.waveform_degree=1", "exchange.1.substeps=true"]
    run_scene(load_scene(TUBE_SCENE, subcycled), tmp_path / "fom", progress=False)
    with RunResults(tmp_path / "fom") as results:
        iterations = int(results.windows.iterations.sum())
        fom = results.fields()["section"]
    calls, _ = recorded_calls(tmp_path / "fom" / "results.h5", {"component": "solid", "input": "pressure",
                                                                  "output": "section", "field": ""})
    assert len(calls.window) == 2 * iterations
    assert main(["train", str(tmp_path / "fom" / "results.h5"), "--config", str(ROOT / "rom_configs" / "tube_rom.toml"),
                 "--set", "snapshots.t_max=4.0", "--out", str(tmp_path / "model.npz")]) == 0
    run_scene(load_scene(TUBE_SCENE, [*subcycled, "components.solid.backend=rom", "components.solid.rom.switch_time=0",
                                      f"components.solid.rom.model={tmp_path / 'model.npz'}"]),
              tmp_path / "rom", progress=False)
    with RunResults(tmp_path / "rom") as results:
        rom = results.fields()["section"]
    assert np.abs(rom - fom).max() < 0.05 * np.abs(fom - 1.0).max() + 1e-3


def test_the_waveforms_matrices_kept_per_time_grid_hold_a_bounded_number_of_bytes(monkeypatch):
    """A participant whose step count changes every window makes a new grid every window: the matrices kept stay
    within CACHE_BYTES (a participant taking 1500 + k steps in window k reached 4.3 GB in 60 windows), and the one
    a window's iterations share is still the one kept."""
    from coupler import waveform
    monkeypatch.setattr(waveform, "CACHE_BYTES", 20 << 20)
    for steps in range(300, 360):                   # (steps + 2)^2 doubles each: about 0.8 MB, 60 grids of them
        inner = np.linspace(0.0, 1.0, steps + 2)[1:-1]
        knots_, matrix = waveform._interpolation(inner.tobytes(), 3)
        assert waveform._interpolation(inner.tobytes(), 3)[1] is matrix       # the same window's next iteration
        waveform.resampling(np.concatenate([[0.0], inner, [1.0]]), 3, np.array([0.5]))
    for cache in (waveform._interpolation, waveform._resampling):
        assert 0 < cache.held[0] <= 20 << 20


NAN_MASS = '''
import numpy as np
from mass_component import Mass


class NanMass(Mass):
    """The example's mass, whose displacement is NaN at its tenth step: the second of a window's four."""

    calls = 0

    def do_step(self, t, dt):
        super().do_step(t, dt)
        NanMass.calls += 1

    def get_values(self, names):
        values = super().get_values(names)
        return {k: v * np.nan for k, v in values.items()} if NanMass.calls == 10 else values
'''


def test_a_non_finite_value_at_a_step_inside_the_window_is_named_at_its_sender(tmp_path):
    """A subcycling component's NaN at an inner step went into the receiver's waveform, and the error blamed the
    receiver; it is refused at the sender, naming the step."""
    import subprocess
    import sys
    shutil.copytree(ROOT / "examples" / "oscillator", tmp_path / "case")
    (tmp_path / "case" / "nan_mass.py").write_text(NAN_MASS)
    scene = (tmp_path / "case" / "scene.toml").read_text()
    (tmp_path / "case" / "scene.toml").write_text(scene.replace('entry = "mass_component:Mass"\nparameters = { side '
                                                                '= "Left"', 'entry = "nan_mass:NanMass"\nparameters '
                                                                '= { side = "Left"', 1))
    done = subprocess.run([sys.executable, "-m", "cosim", "run", str(tmp_path / "case" / "scene.toml"), "--out",
                           str(tmp_path / "run"), "--quiet"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    err = done.stderr.strip()
    assert done.returncode == 2 and "\n" not in err, err
    assert "component 'Mass-Left'" in err and "output 'Displacement-Left' at its step 2 of 4 in the window is not " \
                                              "finite" in err, err
