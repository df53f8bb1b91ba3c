"""The table of study-file keys (`pipeline.study.files.keys`) is the parsers' own: every key a
parser accepts is a row and every row is accepted by a parser, and studies/README.md
shows exactly the generated table.

The parsers are probed from outside: an unknown key is put into every table of every
shipped study (and the test studies), the study is loaded, and the one-line error
lists the keys allowed at that table ("unknown key (allowed: a, b, ...)").  A table
the corpus lacks is probed from a small document written here.
"""
import copy
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from pipeline.__main__ import main
from pipeline.errors import UsageError
from pipeline.study.files import keys
from pipeline.study.files.documents import study_from_document

ROOT = Path(__file__).resolve().parents[3]
CORPUS = sorted((ROOT / "studies").glob("*.toml")) + sorted((ROOT / "tests" / "studies").glob("*.toml"))
PROBE = "zz_probe"
BEGIN, END = "<!-- keys:begin -->", "<!-- keys:end -->"
UNKNOWN = re.compile(r": (?P<field>[^:]*?)\.?" + PROBE + r": unknown key \(allowed: (?P<allowed>[^)]*)\)")

# tables that no shipped study has: a minimal document that reaches each
EXTRA = {
    "disk factors": """
[study]
title = "t"
[scene]
model = "disk"
effects = ["friction", "cyclic_coupling", "mistuning"]
dofs = ["x"]
matrices = { M = [[1.0]], K = [[1.0]] }
[scene.disk]
sectors = 3
engine_order = 1
mistuning = { factors = [1.0, 1.01, 0.99] }
[[scene.contact]]
tangential = ["next.x", "-x"]
ku = 1.0
mu = 0.1
[[scene.excitation]]
dof = "x"
amplitude = 1.0
[sweep]
preload = [1.0]
frequency = { start = 0.5, stop = 1.5, unit = "rad/s" }
""",
}
# a solid blade on exported matrices, one document per format (each takes its own keys)
for _fmt, _files in (("calculix", 'job = "b"'), ("abaqus", 'stiffness = "k", mass = "m"'),
                     ("ansys", 'stiffness = "k", mass = "m", mapping = "k.mapping"'),
                     ("matrix_market", 'stiffness = "k", mass = "m", dofs = "d"')):
    _axis = (', axis = { point = [0.0, 0.0, -0.25], direction = [1.0, 0.0, 0.0] }'
             if _fmt == "calculix" else "")     # the model's engine axis
    EXTRA[f"exported {_fmt}"] = f"""
[study]
title = "t"
kind = "modes"
[scene]
model = "solid_blade"
mesh = "{ROOT / 'meshes' / 'blade_coarse.vtu'}"
matrices = {{ format = "{_fmt}", units = "SI", {_files}{_axis} }}
[modes]
mode_counts = [0, 5]
"""

EXTRA["generated disk sector"] = """
[study]
title = "t"
kind = "modes"
[scene]
model = "solid_blade"
craig_bampton_modes = 4
[scene.blade]
n_chord = 2
n_thick = 1
n_span = 2
[scene.disk]
sectors = 36
hub_radius = 0.12
[scene.disk_sector]
bore_radius = 0.08
[[scene.contact]]
pair = "shroud"
ku = 5e5
mu = 0.3
[modes]
n_frequencies = 2
"""

EXTRA["lumped exported"] = """
[study]
title = "t"
[scene]
model = "lumped"
effects = []
matrices = { format = "matrix_market", stiffness = "k", mass = "m", dofs = "d", damping = "c", units = "SI" }
[[scene.excitation]]
dof = "n1.x"
amplitude = 1.0
[sweep]
frequency = { start = 0.5, stop = 1.5, unit = "rad/s" }
"""


def _tables(doc, path=()):
    """Every table of a parsed TOML document (the first of an array of tables), with
    its key path."""
    yield path, doc
    for k, v in doc.items():
        if isinstance(v, dict):
            yield from _tables(v, path + (k,))
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            yield from _tables(v[0], path + (k, 0))


def _probe(doc, path, file, quick):
    """(field, allowed keys) of the unknown-key error at `path`, or None when the
    document fails elsewhere first (or the dict there is data, not a table)."""
    d = copy.deepcopy(doc)
    t = d
    for k in path:
        t = t[k]
    t[PROBE] = 1
    try:
        study_from_document(d, file=file, name="probe", quick=quick)
    except UsageError as exc:
        m = UNKNOWN.search(str(exc))
        if m:
            return m["field"], {a.strip() for a in m["allowed"].split(",")}
    return None


@pytest.fixture(scope="module")
def probed():
    """{canonical table: [allowed key sets]} over the corpus."""
    docs = [(str(f), tomllib.loads(f.read_text())) for f in CORPUS]
    docs += [(f"<{name}>", tomllib.loads(text)) for name, text in EXTRA.items()]
    out = {}
    for file, doc in docs:
        for path, _ in _tables(doc):
            if path and path[-1] == "next":   # `next = {x2 = -1}` in a contact row: data
                continue
            got = _probe(doc, path, file, quick=bool(path) and path[0] == "quick")
            if got is not None:
                out.setdefault(keys.canonical(got[0]), []).append(got[1])
    return out


def test_every_accepted_key_is_in_the_table(probed):
    table = keys.keys_by_table()
    for t, sets in probed.items():
        assert t in table, f"table [{t}] is not in pipeline/study/files/keys.py"
        for allowed in sets:
            assert allowed <= table[t], f"[{t}]: {sorted(allowed - table[t])} missing from the table"


def test_every_key_in_the_table_is_accepted(probed):
    for t, ks in keys.keys_by_table().items():
        assert t in probed, f"table [{t}] was not reached by any probe"
        accepted = set().union(*probed[t])
        assert ks <= accepted, f"[{t}]: {sorted(ks - accepted)} in the table, accepted nowhere"


def test_every_table_path_is_an_alias_or_a_row():
    table = keys.keys_by_table()
    for a, b in keys.ALIASES.items():
        assert keys.canonical(a) in table, (a, b)


def test_studies_readme_shows_the_generated_table(capsys):
    text = (ROOT / "studies" / "README.md").read_text()
    assert BEGIN in text and END in text
    shown = text.split(BEGIN, 1)[1].split(END, 1)[0].strip()
    assert main(["keys"]) == 0
    printed = capsys.readouterr().out.strip()
    assert printed == keys.markdown().strip()
    assert shown == printed, ("studies/README.md's key table differs from "
                              "`python -m pipeline keys`: paste its output between the markers")


def test_units_and_solver_defaults_come_from_the_code():
    from pipeline.study.files.study_types import SWEEP_AXES, SolverSettings

    rows = {(t, k): (u, d) for t, k, u, d, _ in keys.rows()}
    for axis, (unit, _) in SWEEP_AXES.items():
        assert rows[("sweep", axis)][0] == unit
    s = SolverSettings()
    assert rows[("solver", "harmonics")][1] == str(s.harmonics)
    assert rows[("solver", "max_points")][1] == str(s.max_points)


def test_the_walkthrough_study_in_studies_readme_is_valid():
    """The study of "Write your own study" loads, full and quick, and declares what it says."""
    from pipeline.study.files.documents import parse_study

    text = (ROOT / "studies" / "README.md").read_text()
    section = text.split("## Write your own study", 1)[1]
    toml = re.search(r"```toml\n(.*?)```", section, re.S).group(1)
    full = parse_study(toml, file="<walkthrough>", name="my_study")
    quick = parse_study(toml, file="<walkthrough>", name="my_study", quick=True)
    assert full.sweep.axes["preload"] == (0.5, 2.0, 10.0)
    assert quick.sweep.axes["preload"] == (2.0,) and quick.solver.harmonics == 3
    assert full.sweep.frequency.unit == "Hz"
    # "its modes are at 22.5 and 45.0 Hz with the damper open, 26.3 and 51.0 Hz with it stuck"
    import numpy as np
    from pipeline.model.build import build_system
    from pipeline.model.system import natural_frequencies

    stated = [float(x) for x in re.search(
        r"modes are\s+at ([\d.]+) and ([\d.]+) Hz\s+with the damper open, ([\d.]+) and\s+"
        r"([\d.]+) Hz\s+with it stuck", section).groups()]
    s = build_system(full.scene, {"preload": 2.0})
    got = np.concatenate([natural_frequencies(s, m)[:2] for m in ("open", "stuck")]) / (2 * np.pi)
    np.testing.assert_allclose(got, stated, atol=0.05)


@pytest.mark.parametrize("args, what", [((150.0, 250.0, "hz"), "unit must be 'rad/s' or 'Hz', got 'hz'"),
                                        ((150.0, 250.0, "rpm"), "unit must be 'rad/s' or 'Hz'"),
                                        ((-10.0, 250.0, "rad/s"), "start must be a finite number > 0"),
                                        ((150.0, float("nan"), "Hz"), "stop must be a finite number > 0"),
                                        ((150.0, 150.0, "Hz"), "start and stop are equal")])
def test_a_frequency_range_built_in_python_meets_the_study_files_rules(args, what):
    """A Python-built study's range is checked as a study file's is: an unknown unit
    would otherwise run in rad/s under another unit's label."""
    from pipeline.study.files.study_types import FrequencyRange
    with pytest.raises(ValueError, match=re.escape(what)):
        FrequencyRange(*args)
    assert FrequencyRange(150, 250.0, "Hz").omega_stop == pytest.approx(500 * np.pi)
