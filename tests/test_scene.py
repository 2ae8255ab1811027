import pytest

from cosim.errors import SceneError
from cosim.scene import load_scene as load_only
from coupler.scene_rules import resolve_plugins


def load_scene(path, overrides=()):
    """A scene as ``cosim run`` sees it: loaded, then its plug-in tables resolved by the coupler."""
    scene = load_only(path, overrides)
    resolve_plugins(scene)
    return scene


def write(tmp_path, text):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def test_tube_scene_loads_with_the_papers_settings(tube_scene_path):
    scene = load_scene(tube_scene_path)
    assert scene["time"] == {"start": 0.0, "end": 120.0, "dt": 0.1}
    acceleration = scene["coupling"]["acceleration"]
    assert (acceleration["type"], acceleration["initial_relaxation"], acceleration["max_used_iterations"],
            acceleration["reused_time_windows"], acceleration["filter"], acceleration["filter_limit"]) == \
        ("iqn-ils", 0.01, 50, 8, "qr2", 1e-3)
    assert [(m["data"], m["type"], m["limit"]) for m in scene["coupling"]["convergence"]] == \
        [("pressure", "relative", 1e-4), ("section", "relative", 1e-4)]
    assert scene.component_parameters("fluid")["inlet"]["f"] == 2.0


def test_set_overrides_values_and_records_them(tube_scene_path):
    scene = load_scene(tube_scene_path, ["inlet.f=0.9", "inlet.h=4", "time.end=18",
                                         "inlet.table=some/path.csv", "coupling.convergence.1.limit=1e-6"])
    assert scene["inlet"]["f"] == 0.9 and scene["inlet"]["h"] == 4 and scene["time"]["end"] == 18.0
    assert scene["inlet"]["table"] == "some/path.csv"
    assert scene["coupling"]["convergence"][1]["limit"] == 1e-6
    assert "# --set inlet.f=0.9" in scene.text


@pytest.mark.parametrize("override, message", [
    ("coupling.acceleration.inital_relaxation=0.1",
     "unknown key 'coupling.acceleration.inital_relaxation'.*did you mean 'coupling.acceleration.initial_relaxation'"),
    ("coupling.max_iterations=ten", "'coupling.max_iterations' must be an integer"),
    ("coupling.scheme=jacobi", "'coupling.scheme' is 'jacobi'; known coupling schemes: serial-explicit"),
    ('coupling.acceleration={type="aitken", filter="qr2"}', "unknown key 'coupling.acceleration.filter'"),
    ('exchange.0.mapping={type="rbf"}', "missing key 'exchange.0.mapping.support_radius'"),
    ('exchange.0.mapping={type="nearest-neighbour", constraint="sideways"}',
     "'exchange.0.mapping.constraint' is 'sideways'; allowed: consistent, conservative"),
    ("coupling.predictor=psychic", "'coupling.predictor' is 'psychic'; allowed: none, acceleration"),
    ("coupling.scheme=serial-explicit", "'coupling.acceleration' is set, but serial-explicit takes one iteration"),
    ("coupling.convergence.0.type=any-of", "unknown key 'coupling.convergence.0.limit'.*known keys: data, measures"),
    ('coupling.convergence.0={data="pressure", type="any-of"}', "missing key 'coupling.convergence.0.measures'"),
    ("coupling.participants=[\"fluid\", \"soild\"]", "'coupling.participants.1' is 'soild', not a component"),
    ("time.dt=-0.1", r"'time.dt' is -0.1; allowed: a number > 0"),
    ("coupling.convergence.0.data=presure", "'coupling.convergence.0.data' is 'presure', not exchanged data"),
    ("exchange.0.mapping=magic", "'exchange.0.mapping.type' is 'magic'; known mappings: identity"),
    ("components.solid.entyr=x", "unknown key 'components.solid.entyr'.*did you mean 'components.solid.entry'"),
    ("inlte.f=1", "unknown key 'inlte'.*did you mean 'inlet'"),
    ('components.solid.cores=["0"]', r"'components.solid.cores.0' must be a core number, got '0'"),
    ("components.solid.cores=[4096]", r"'components.solid.cores' names core 4096; this process may use cores 0"),
    ("components.solid.threads=100000", r"'components.solid.threads' is 100000; at most \d+ \(4 a core of this "
                                        r"machine's \d+\)"),
    ("components.solid.substeps=1000000", r"'components.solid.substeps' is 1000000; allowed: \[1, 10,000\]"),
    ('coupling.convergence=[{data="section", type="min-iterations", iterations=91}]',
     r"'coupling.convergence.0.iterations' is 91, above 'coupling.max_iterations' \(90\): no window could converge"),
    ('output.watch_points=[{component="solid", mesh="axis", name="a/b", coordinate=[0.0]}]',
     r"'output.watch_points.0.name' is 'a/b': a watch point's name becomes a file name"),
])
def test_bad_scenes_name_the_key(tube_scene_path, override, message):
    with pytest.raises(SceneError, match=message):
        load_scene(tube_scene_path, [override])


def test_misspelt_key_in_a_file_names_the_file(tmp_path, tube_scene_path):
    text = tube_scene_path.read_text().replace("max_iterations = 90", "max_iteration = 90")
    with pytest.raises(SceneError, match=r"unknown key 'coupling.max_iteration' in .*scene.toml; "
                                         r"did you mean 'coupling.max_iterations'"):
        load_scene(write(tmp_path, text))


def test_missing_required_key(tmp_path, tube_scene_path):
    text = tube_scene_path.read_text().replace("dt = 0.1\n", "")
    with pytest.raises(SceneError, match="missing key 'time.dt'"):
        load_scene(write(tmp_path, text))


def test_the_acceleration_predictor_replaces_extrapolation(tube_scene_path):
    assert load_scene(tube_scene_path, ["coupling.predictor=acceleration"])["coupling"]["predictor"] == "acceleration"
    with pytest.raises(SceneError, match="'coupling.extrapolation_order' must be 0, got 1"):
        load_scene(tube_scene_path, ["coupling.predictor=acceleration", "coupling.extrapolation_order=1"])


def test_serial_explicit_runs_without_acceleration_or_its_predictor(tube_scene_path):
    explicit = ["coupling.scheme=serial-explicit", 'coupling.acceleration="none"']
    assert load_scene(tube_scene_path, explicit)["coupling"]["scheme"] == "serial-explicit"
    with pytest.raises(SceneError, match="'coupling.predictor' is set, but serial-explicit"):
        load_scene(tube_scene_path, [*explicit, "coupling.predictor=acceleration"])
