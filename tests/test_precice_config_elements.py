"""Every element of preCICE 3.4.1's configuration (its DTD, `precice-config-doc dtd`: 88 elements), in a
configuration of two participants: each is read into what it configures (the acceleration's filter, the mapping's
basis, a measure's kind...), accepted as output or transport that cosim does its own way (a note `cosim check`
prints), or refused in one line naming the file, the line, the element and why."""

from __future__ import annotations

import pytest

from cosim.errors import SceneError
from precice_compat.config import read_config

# preCICE 3.4.1's configuration elements, as its DTD lists them
PRECICE_ELEMENTS = (
    "absolute-convergence-measure absolute-or-relative-convergence-measure acceleration:IQN-ILS acceleration:IQN-IMVJ "
    "acceleration:aitken acceleration:constant action:divide-by-area action:multiply-by-area action:python "
    "action:recorder action:summation basis-function:compact-polynomial-c0 basis-function:compact-polynomial-c2 "
    "basis-function:compact-polynomial-c4 basis-function:compact-polynomial-c6 basis-function:compact-polynomial-c8 "
    "basis-function:compact-tps-c2 basis-function:gaussian basis-function:inverse-multiquadrics "
    "basis-function:multiquadrics basis-function:thin-plate-splines basis-function:volume-splines coupling-scheme:multi "
    "coupling-scheme:parallel-explicit coupling-scheme:parallel-implicit coupling-scheme:serial-explicit "
    "coupling-scheme:serial-implicit data data:scalar data:vector exchange executor:cpu executor:cuda executor:hip "
    "executor:openmp executor:sycl export:csv export:vtk export:vtp export:vtu filter imvj-restart-mode "
    "initial-relaxation intra-comm:mpi intra-comm:sockets log m2n:mpi m2n:mpi-multiple-ports m2n:sockets "
    "mapping:axial-geometric-multiscale mapping:coarse-graining mapping:linear-cell-interpolation "
    "mapping:nearest-neighbor mapping:nearest-neighbor-gradient mapping:nearest-projection "
    "mapping:radial-geometric-multiscale mapping:rbf mapping:rbf-global-direct mapping:rbf-global-iterative "
    "mapping:rbf-pum-direct max-iterations max-time max-time-windows max-used-iterations mesh min-iterations module "
    "participant participants path precice-configuration preconditioner profiling provide-mesh read-data receive-mesh "
    "relative-convergence-measure relaxation residual-relative-convergence-measure sink source-data target-data "
    "time-window-size time-windows-reused use-data watch-integral watch-point write-data").split()

BASE = """<?xml version="1.0"?>
<precice-configuration experimental="true">
  TOP
  <data:vector name="F"/><data:scalar name="U"/>
  <mesh name="A-Mesh" dimensions="2"><use-data name="F"/><use-data name="U"/></mesh>
  <mesh name="B-Mesh" dimensions="2"><use-data name="F"/><use-data name="U"/></mesh>
  <participant name="A"><provide-mesh name="A-Mesh"/><write-data name="F" mesh="A-Mesh"/>
    <read-data name="U" mesh="A-Mesh"/>PARTICIPANT</participant>
  <participant name="B"><provide-mesh name="B-Mesh"/><receive-mesh name="A-Mesh" from="A"/>
    <write-data name="U" mesh="B-Mesh"/><read-data name="F" mesh="B-Mesh"/>
    MAPPING
    <mapping:nearest-neighbor direction="write" from="B-Mesh" to="A-Mesh" constraint="consistent"/>
  </participant>
  M2N
  <coupling-scheme:KIND>
    PARTICIPANTS
    <max-time value="1.0"/><time-window-size value="0.1"/>ITERATIONS
    <exchange data="F" mesh="A-Mesh" from="A" to="B"/>
    <exchange data="U" mesh="A-Mesh" from="B" to="A"/>
    MEASURE
    ACCELERATION
  </coupling-scheme:KIND>
</precice-configuration>
"""
DEFAULTS = {"TOP": "", "PARTICIPANT": "",
            "MAPPING": '<mapping:nearest-neighbor direction="read" from="A-Mesh" to="B-Mesh" constraint="consistent"/>',
            "M2N": '<m2n:sockets acceptor="A" connector="B" exchange-directory=".."/>',
            "KIND": "serial-implicit", "PARTICIPANTS": '<participants first="A" second="B"/>', "ITERATIONS": '<max-iterations value="10"/>',
            "MEASURE": '<relative-convergence-measure data="U" mesh="A-Mesh" limit="1e-6"/>',
            "ACCELERATION": '<acceleration:IQN-ILS><data name="U" mesh="A-Mesh"/><initial-relaxation value="0.5"/>'
                            'ACC</acceleration:IQN-ILS>', "ACC": ""}
RBF = '<mapping:{kind} direction="read" from="A-Mesh" to="B-Mesh" constraint="consistent"{extra}>{inner}</mapping:{kind}>'
C2 = '<basis-function:compact-polynomial-c2 support-radius="0.5"/>'
EXPLICIT = {"ITERATIONS": "", "MEASURE": "", "ACCELERATION": ""}
# element -> the parts of BASE it changes
CASES = {
    "precice-configuration": {},
    "log": {"TOP": '<log><sink type="stream" output="stdout" filter="%Severity% > debug" enabled="true"/></log>'},
    "sink": {"TOP": '<log><sink type="file" output="log.txt" enabled="false"/></log>'},
    "profiling": {"TOP": '<profiling mode="fundamental"/>'},
    "data:scalar": {}, "data:vector": {}, "mesh": {}, "use-data": {}, "participant": {}, "provide-mesh": {},
    "receive-mesh": {}, "write-data": {}, "read-data": {}, "exchange": {}, "participants": {}, "max-time": {},
    "time-window-size": {}, "max-iterations": {},
    "data": {},
    "watch-point": {"PARTICIPANT": '<watch-point mesh="A-Mesh" name="P" coordinate="0.0;0.0"/>'},
    "watch-integral": {"PARTICIPANT": '<watch-integral mesh="A-Mesh" name="I" scale-with-connectivity="false"/>'},
    "export:vtu": {"PARTICIPANT": '<export:vtu directory="out"/>'},
    "export:vtk": {"PARTICIPANT": '<export:vtk directory="out"/>'},
    "export:vtp": {"PARTICIPANT": '<export:vtp directory="out"/>'},
    "export:csv": {"PARTICIPANT": '<export:csv directory="out"/>'},
    "intra-comm:sockets": {"PARTICIPANT": '<intra-comm:sockets/>'},
    "intra-comm:mpi": {"PARTICIPANT": '<intra-comm:mpi/>'},
    "action:multiply-by-area": {"PARTICIPANT": '<action:multiply-by-area mesh="A-Mesh" timing="write-mapping-post">'
                                               '<target-data name="F"/></action:multiply-by-area>'},
    "action:divide-by-area": {"PARTICIPANT": '<action:divide-by-area mesh="A-Mesh" timing="write-mapping-post">'
                                             '<target-data name="F"/></action:divide-by-area>'},
    "action:summation": {"PARTICIPANT": '<action:summation mesh="A-Mesh" timing="write-mapping-post">'
                                        '<source-data name="F"/><target-data name="F"/></action:summation>'},
    "action:recorder": {"PARTICIPANT": '<action:recorder mesh="A-Mesh" timing="write-mapping-post"/>'},
    "action:python": {"PARTICIPANT": '<action:python mesh="A-Mesh" timing="write-mapping-post"><path name="."/>'
                                     '<module name="act"/><source-data name="F"/><target-data name="F"/>'
                                     '</action:python>'},
    "source-data": "action:summation", "target-data": "action:multiply-by-area", "path": "action:python",
    "module": "action:python",
    "mapping:nearest-neighbor": {},
    "mapping:nearest-projection": {"MAPPING": '<mapping:nearest-projection direction="read" from="A-Mesh" to="B-Mesh" constraint="consistent"/>'},
    "mapping:linear-cell-interpolation": {"MAPPING": '<mapping:linear-cell-interpolation direction="read" from="A-Mesh" to="B-Mesh" constraint="consistent"/>'},
    "mapping:nearest-neighbor-gradient": {"MAPPING": '<mapping:nearest-neighbor-gradient direction="read" from="A-Mesh" to="B-Mesh" constraint="consistent"/>'},
    "mapping:rbf": {"MAPPING": RBF.format(kind="rbf", extra="", inner=C2)},
    "mapping:rbf-global-direct": {"MAPPING": RBF.format(kind="rbf-global-direct", extra="", inner=C2)},
    "mapping:rbf-global-iterative": {"MAPPING": RBF.format(kind="rbf-global-iterative", extra=' solver-rtol="1e-9"', inner=C2)},
    "mapping:rbf-pum-direct": {"MAPPING": RBF.format(kind="rbf-pum-direct", extra=' vertices-per-cluster="50"', inner=C2)},
    "mapping:axial-geometric-multiscale": {"MAPPING": '<mapping:axial-geometric-multiscale direction="read" from="A-Mesh" to="B-Mesh" constraint="consistent" type="spread" radius="1.0"/>'},
    "mapping:radial-geometric-multiscale": {"MAPPING": '<mapping:radial-geometric-multiscale direction="read" from="A-Mesh" to="B-Mesh" constraint="consistent" type="collect" radius="1.0"/>'},
    "mapping:coarse-graining": {"MAPPING": '<mapping:coarse-graining direction="read" from="A-Mesh" to="B-Mesh" constraint="conservative" grain-dim="0.1"/>'},
    "executor:cpu": {"MAPPING": RBF.format(kind="rbf-global-direct", extra="", inner=C2 + '<executor:cpu/>')},
    "executor:openmp": {"MAPPING": RBF.format(kind="rbf-global-iterative", extra="", inner=C2 + '<executor:openmp n-threads="2"/>')},
    "executor:cuda": {"MAPPING": RBF.format(kind="rbf-global-direct", extra="", inner=C2 + '<executor:cuda gpu-device-id="0"/>')},
    "executor:hip": {"MAPPING": RBF.format(kind="rbf-global-direct", extra="", inner=C2 + '<executor:hip gpu-device-id="0"/>')},
    "executor:sycl": {"MAPPING": RBF.format(kind="rbf-pum-direct", extra="", inner=C2 + '<executor:sycl execution-mode="minimal-memory"/>')},
    "m2n:sockets": {},
    "m2n:mpi": {"M2N": '<m2n:mpi acceptor="A" connector="B" exchange-directory=".."/>'},
    "m2n:mpi-multiple-ports": {"M2N": '<m2n:mpi-multiple-ports acceptor="A" connector="B" exchange-directory=".."/>'},
    "coupling-scheme:serial-implicit": {},
    "coupling-scheme:parallel-implicit": {"KIND": "parallel-implicit"},
    "coupling-scheme:serial-explicit": {"KIND": "serial-explicit", **EXPLICIT},
    "coupling-scheme:parallel-explicit": {"KIND": "parallel-explicit", **EXPLICIT},
    "coupling-scheme:multi": {"KIND": "multi", "PARTICIPANTS": '<participant name="A" control="yes"/><participant name="B"/>'},
    "max-time-windows": {"ITERATIONS": '<max-iterations value="10"/><max-time-windows value="5"/>'},
    "min-iterations": {"ITERATIONS": '<max-iterations value="10"/><min-iterations value="2"/>'},
    "relative-convergence-measure": {},
    "absolute-convergence-measure": {"MEASURE": '<absolute-convergence-measure data="U" mesh="A-Mesh" limit="1e-6"/>'},
    "absolute-or-relative-convergence-measure": {"MEASURE": '<absolute-or-relative-convergence-measure data="U" mesh="A-Mesh" abs-limit="1e-6" rel-limit="1e-4"/>'},
    "residual-relative-convergence-measure": {"MEASURE": '<residual-relative-convergence-measure data="U" mesh="A-Mesh" limit="1e-3"/>'},
    "acceleration:IQN-ILS": {}, "initial-relaxation": {},
    "acceleration:IQN-IMVJ": {"ACCELERATION": '<acceleration:IQN-IMVJ><data name="U" mesh="A-Mesh"/><initial-relaxation value="0.5"/><imvj-restart-mode type="RS-ZERO" chunk-size="4"/></acceleration:IQN-IMVJ>'},
    "imvj-restart-mode": "acceleration:IQN-IMVJ",
    "acceleration:aitken": {"ACCELERATION": '<acceleration:aitken><data name="U" mesh="A-Mesh"/><initial-relaxation value="0.5"/></acceleration:aitken>'},
    "acceleration:constant": {"ACCELERATION": '<acceleration:constant><relaxation value="0.5"/></acceleration:constant>'},
    "relaxation": "acceleration:constant",
    "max-used-iterations": {"ACC": '<max-used-iterations value="20"/>'},
    "time-windows-reused": {"ACC": '<time-windows-reused value="4"/>'},
    "filter": {"ACC": '<filter type="QR2" limit="1e-2"/>'},
    "preconditioner": {"ACC": '<preconditioner type="residual-sum"/>'},
}
for name in ("compact-polynomial-c0", "compact-polynomial-c2", "compact-polynomial-c4", "compact-polynomial-c6",
             "compact-polynomial-c8", "compact-tps-c2"):
    CASES[f"basis-function:{name}"] = {"MAPPING": RBF.format(kind="rbf", extra="", inner=f'<basis-function:{name} support-radius="0.5"/>')}
for name in ("gaussian", "inverse-multiquadrics", "multiquadrics"):
    CASES[f"basis-function:{name}"] = {"MAPPING": RBF.format(kind="rbf", extra="", inner=f'<basis-function:{name} shape-parameter="2.0"/>')}
for name in ("thin-plate-splines", "volume-splines"):
    CASES[f"basis-function:{name}"] = {"MAPPING": RBF.format(kind="rbf", extra="", inner=f'<basis-function:{name}/>')}


# the elements every configuration above holds: read in the base one
BASE_ELEMENTS = ("precice-configuration", "data:scalar", "data:vector", "mesh", "use-data", "participant",
                 "provide-mesh", "receive-mesh", "write-data", "read-data", "exchange", "participants", "max-time",
                 "time-window-size", "max-iterations", "data", "mapping:nearest-neighbor", "m2n:sockets",
                 "coupling-scheme:serial-implicit", "relative-convergence-measure", "acceleration:IQN-ILS",
                 "initial-relaxation")


def config_of(element: str) -> str:
    spec = CASES[element]
    if isinstance(spec, str):       # an element that lives inside another: its parent's case
        spec = CASES[spec]
    parts = {**DEFAULTS, **spec}
    text = BASE
    for key in ("ACCELERATION", "ACC", "TOP", "PARTICIPANTS", "PARTICIPANT", "MAPPING", "M2N", "KIND", "ITERATIONS",
                "MEASURE"):
        text = text.replace(key, parts[key])
    return text


EFFECTS = {'absolute-convergence-measure': {'scheme.measures[0].type': 'absolute'},
 'absolute-or-relative-convergence-measure': {'scheme.measures[0].measures[0].limit': 1e-06,
                                              'scheme.measures[0].measures[0].type': 'absolute',
                                              'scheme.measures[0].measures[1].limit': 0.0001,
                                              'scheme.measures[0].measures[1].type': 'relative',
                                              'scheme.measures[0].type': 'any-of'},
 'acceleration:IQN-IMVJ': {'scheme.acceleration.restart_windows': 4, 'scheme.acceleration.type': 'iqn-imvj'},
 'acceleration:aitken': {'scheme.acceleration.type': 'aitken'},
 'acceleration:constant': {'scheme.acceleration.relaxation': 0.5, 'scheme.acceleration.type': 'constant'},
 'basis-function:compact-polynomial-c0': {'mappings[0].kind': 'rbf',
                                          'mappings[0].settings.basis': 'compact-polynomial-c0',
                                          'mappings[0].settings.polynomial': 'separate',
                                          'mappings[0].settings.support_radius': 0.5},
 'basis-function:compact-polynomial-c2': {'mappings[0].kind': 'rbf',
                                          'mappings[0].settings.basis': 'compact-polynomial-c2',
                                          'mappings[0].settings.polynomial': 'separate',
                                          'mappings[0].settings.support_radius': 0.5},
 'basis-function:compact-polynomial-c4': {'mappings[0].kind': 'rbf',
                                          'mappings[0].settings.basis': 'compact-polynomial-c4',
                                          'mappings[0].settings.polynomial': 'separate',
                                          'mappings[0].settings.support_radius': 0.5},
 'basis-function:compact-polynomial-c6': {'mappings[0].kind': 'rbf',
                                          'mappings[0].settings.basis': 'compact-polynomial-c6',
                                          'mappings[0].settings.polynomial': 'separate',
                                          'mappings[0].settings.support_radius': 0.5},
 'basis-function:compact-polynomial-c8': {'mappings[0].kind': 'rbf',
                                          'mappings[0].settings.basis': 'compact-polynomial-c8',
                                          'mappings[0].settings.polynomial': 'separate',
                                          'mappings[0].settings.support_radius': 0.5},
 'basis-function:compact-tps-c2': {'mappings[0].kind': 'rbf',
                                   'mappings[0].settings.basis': 'compact-tps-c2',
                                   'mappings[0].settings.polynomial': 'separate',
                                   'mappings[0].settings.support_radius': 0.5},
 'basis-function:gaussian': {'mappings[0].kind': 'rbf',
                             'mappings[0].settings.basis': 'gaussian',
                             'mappings[0].settings.polynomial': 'separate',
                             'mappings[0].settings.shape_parameter': 2.0},
 'basis-function:inverse-multiquadrics': {'mappings[0].kind': 'rbf',
                                          'mappings[0].settings.basis': 'inverse-multiquadrics',
                                          'mappings[0].settings.polynomial': 'separate',
                                          'mappings[0].settings.shape_parameter': 2.0},
 'basis-function:multiquadrics': {'mappings[0].kind': 'rbf',
                                  'mappings[0].settings.basis': 'multiquadrics',
                                  'mappings[0].settings.polynomial': 'separate',
                                  'mappings[0].settings.shape_parameter': 2.0},
 'basis-function:thin-plate-splines': {'mappings[0].kind': 'rbf',
                                       'mappings[0].settings.basis': 'thin-plate-splines',
                                       'mappings[0].settings.polynomial': 'separate'},
 'basis-function:volume-splines': {'mappings[0].kind': 'rbf',
                                   'mappings[0].settings.basis': 'volume-splines',
                                   'mappings[0].settings.polynomial': 'separate'},
 'coupling-scheme:multi': {'scheme.kind': 'multi'},
 'coupling-scheme:parallel-explicit': {'scheme.acceleration': None, 'scheme.kind': 'parallel-explicit'},
 'coupling-scheme:parallel-implicit': {'scheme.kind': 'parallel-implicit'},
 'coupling-scheme:serial-explicit': {'scheme.acceleration': None, 'scheme.kind': 'serial-explicit'},
 'executor:cpu': {'mappings[0].kind': 'rbf',
                  'mappings[0].settings.basis': 'compact-polynomial-c2',
                  'mappings[0].settings.polynomial': 'separate',
                  'mappings[0].settings.support_radius': 0.5},
 'executor:cuda': {'mappings[0].kind': 'rbf',
                   'mappings[0].settings.basis': 'compact-polynomial-c2',
                   'mappings[0].settings.polynomial': 'separate',
                   'mappings[0].settings.support_radius': 0.5},
 'executor:hip': {'mappings[0].kind': 'rbf',
                  'mappings[0].settings.basis': 'compact-polynomial-c2',
                  'mappings[0].settings.polynomial': 'separate',
                  'mappings[0].settings.support_radius': 0.5},
 'executor:openmp': {'mappings[0].kind': 'rbf',
                     'mappings[0].settings.basis': 'compact-polynomial-c2',
                     'mappings[0].settings.polynomial': 'separate',
                     'mappings[0].settings.support_radius': 0.5},
 'executor:sycl': {'mappings[0].kind': 'rbf',
                   'mappings[0].settings.basis': 'compact-polynomial-c2',
                   'mappings[0].settings.polynomial': 'separate',
                   'mappings[0].settings.support_radius': 0.5},
 'export:csv': {'exports[0].directory': 'out',
                'exports[0].every_iteration': False,
                'exports[0].every_n_time_windows': 1,
                'exports[0].format': 'csv'},
 'export:vtk': {'exports[0].directory': 'out',
                'exports[0].every_iteration': False,
                'exports[0].every_n_time_windows': 1,
                'exports[0].format': 'vtk'},
 'export:vtu': {'exports[0].directory': 'out',
                'exports[0].every_iteration': False,
                'exports[0].every_n_time_windows': 1,
                'exports[0].format': 'vtu'},
 'filter': {'scheme.acceleration.filter': 'qr2', 'scheme.acceleration.filter_limit': 0.01},
 'imvj-restart-mode': {'scheme.acceleration.restart_windows': 4, 'scheme.acceleration.type': 'iqn-imvj'},
 'mapping:linear-cell-interpolation': {'mappings[0].kind': 'cell-interpolation',
                                       'mappings[0].settings.without_elements': 'nearest-node'},
 'mapping:nearest-neighbor-gradient': {'mappings[0].kind': 'nearest-neighbour-gradient'},
 'mapping:nearest-projection': {'mappings[0].kind': 'nearest-element',
                                'mappings[0].settings.local_coordinate_tolerance': 0.0,
                                'mappings[0].settings.without_elements': 'nearest-node'},
 'mapping:rbf': {'mappings[0].kind': 'rbf',
                 'mappings[0].settings.basis': 'compact-polynomial-c2',
                 'mappings[0].settings.polynomial': 'separate',
                 'mappings[0].settings.support_radius': 0.5},
 'mapping:rbf-global-direct': {'mappings[0].kind': 'rbf',
                               'mappings[0].settings.basis': 'compact-polynomial-c2',
                               'mappings[0].settings.polynomial': 'separate',
                               'mappings[0].settings.support_radius': 0.5},
 'mapping:rbf-global-iterative': {'mappings[0].kind': 'rbf',
                                  'mappings[0].settings.basis': 'compact-polynomial-c2',
                                  'mappings[0].settings.polynomial': 'separate',
                                  'mappings[0].settings.support_radius': 0.5},
 'mapping:rbf-pum-direct': {'mappings[0].kind': 'rbf',
                            'mappings[0].settings.basis': 'compact-polynomial-c2',
                            'mappings[0].settings.polynomial': 'separate',
                            'mappings[0].settings.support_radius': 0.5},
 'max-time-windows': {'scheme.max_windows': 5},
 'max-used-iterations': {'scheme.acceleration.max_used_iterations': 20},
 'min-iterations': {'scheme.min_iterations': 2},
 'preconditioner': {'scheme.acceleration.preconditioner': 'residual-sum'},
 'relaxation': {'scheme.acceleration.relaxation': 0.5, 'scheme.acceleration.type': 'constant'},
 'residual-relative-convergence-measure': {'scheme.measures[0].limit': 0.001,
                                           'scheme.measures[0].type': 'residual-relative'},
 'time-windows-reused': {'scheme.acceleration.reused_time_windows': 4},
 'watch-point': {'watch[0].coordinate[0]': 0.0,
                 'watch[0].coordinate[1]': 0.0,
                 'watch[0].mesh': 'A-Mesh',
                 'watch[0].name': 'P'}}
NOTES = {'executor:cpu': '<executor:cpu>',
 'executor:cuda': '<executor:cuda>',
 'executor:hip': '<executor:hip>',
 'executor:openmp': '<executor:openmp>',
 'executor:sycl': '<executor:sycl>',
 'export:vtp': "<export:vtp> of participant 'A'",
 'intra-comm:mpi': "<intra-comm:mpi> of participant 'A'",
 'intra-comm:sockets': "<intra-comm:sockets> of participant 'A'",
 'log': '<log>',
 'm2n:mpi': '<m2n:mpi>',
 'm2n:mpi-multiple-ports': '<m2n:mpi-multiple-ports>',
 'mapping:rbf-global-iterative': '<mapping:rbf-global-iterative>',
 'mapping:rbf-pum-direct': '<mapping:rbf-pum-direct>',
 'profiling': '<profiling>',
 'sink': '<log>'}
REFUSED = {'action:divide-by-area': 'actions are not supported by cosim: compute the quantity in the participant',
 'action:multiply-by-area': 'actions are not supported by cosim: compute the quantity in the participant',
 'action:python': 'actions are not supported by cosim: compute the quantity in the participant',
 'action:recorder': 'actions are not supported by cosim: compute the quantity in the participant',
 'action:summation': 'actions are not supported by cosim: compute the quantity in the participant',
 'mapping:axial-geometric-multiscale': "the mapping 'axial-geometric-multiscale' is not supported by cosim: use "
                                       'nearest-neighbor, nearest-neighbor-gradient, nearest-projection, '
                                       'linear-cell-interpolation or rbf',
 'mapping:coarse-graining': "the mapping 'coarse-graining' (particles to a continuum) is not supported by cosim: "
                            'use nearest-neighbor, nearest-neighbor-gradient, nearest-projection, '
                            'linear-cell-interpolation or rbf',
 'mapping:radial-geometric-multiscale': "the mapping 'radial-geometric-multiscale' is not supported by cosim: use "
                                        'nearest-neighbor, nearest-neighbor-gradient, nearest-projection, '
                                        'linear-cell-interpolation or rbf',
 'module': 'actions are not supported by cosim: compute the quantity in the participant',
 'path': 'actions are not supported by cosim: compute the quantity in the participant',
 'source-data': 'actions are not supported by cosim: compute the quantity in the participant',
 'target-data': 'actions are not supported by cosim: compute the quantity in the participant',
 'watch-integral': 'watch integrals are not supported by cosim: a <watch-point> logs the data at a vertex, and '
                   'results.h5 holds every field at every window'}


def flat(value, prefix: str = "") -> dict:
    if isinstance(value, dict):
        return {k: v for key, item in value.items() for k, v in flat(item, f"{prefix}.{key}" if prefix else key).items()}
    if isinstance(value, list):
        return {k: v for i, item in enumerate(value) for k, v in flat(item, f"{prefix}[{i}]").items()}
    return {prefix: value}


def view(config) -> dict:
    """What a configuration was read into: its scheme, mappings, watch points and exports, flattened."""
    participants = list(config.participants.values())
    return flat({"scheme": config.scheme, "mappings": [m.__dict__ for p in participants for m in p.mappings],
                 "watch": [w for p in participants for w in p.watch_points],
                 "exports": [x for p in participants for x in p.exports]})


def test_the_audit_holds_every_element_of_precices_configuration():
    assert len(PRECICE_ELEMENTS) == 88 and sorted(CASES) == sorted(PRECICE_ELEMENTS)
    assert not set(EFFECTS) & set(REFUSED) and not set(BASE_ELEMENTS) & (set(EFFECTS) | set(REFUSED))


@pytest.mark.parametrize("element", PRECICE_ELEMENTS)
def test_each_element_is_read_as_precice_configures_it_or_refused_in_one_line(tmp_path, element):
    path = tmp_path / "precice-config.xml"
    path.write_text(config_of(element))
    assert f"<{element} " in path.read_text() or f"<{element}>" in path.read_text() or f"<{element}/>" in \
        path.read_text()
    if element in REFUSED:
        with pytest.raises(SceneError) as refused:
            read_config(path)
        message = str(refused.value)
        assert "\n" not in message and message.startswith(f"{path}, line ") and message.endswith(REFUSED[element])
        return
    config = read_config(path)
    found = view(config)
    assert {key: found.get(key) for key in EFFECTS.get(element, {})} == EFFECTS.get(element, {})
    if element in NOTES:
        assert any(note.startswith(NOTES[element]) for note in config.notes), config.notes
    if element in BASE_ELEMENTS:
        assert found["scheme.kind"] == "serial-implicit" and found["scheme.acceleration.type"] == "iqn-ils"
        assert found["scheme.acceleration.initial_relaxation"] == 0.5 and found["scheme.max_iterations"] == 10
        assert found["scheme.measures[0].type"] == "relative" and found["mappings[0].kind"] == "nearest-neighbour"
        assert (found["scheme.window"], found["scheme.max_time"]) == (0.1, 1.0)


def test_an_executor_a_mapping_does_not_take_is_refused_in_one_line(tmp_path):
    """preCICE's executors by mapping: rbf-global-direct takes cpu, cuda and hip; sycl only rbf-pum-direct."""
    path = tmp_path / "precice-config.xml"
    path.write_text(config_of("executor:sycl").replace("rbf-pum-direct", "rbf-global-direct"))
    with pytest.raises(SceneError, match=r"line \d+: <executor:sycl>: <mapping:rbf-global-direct> takes no executor "
                                         r"'sycl' \(preCICE's for it: cpu, cuda, hip\)$"):
        read_config(path)
