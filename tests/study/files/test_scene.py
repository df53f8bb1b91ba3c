"""Study files: the three paper examples, the bad-study corpus, a loader fuzz test."""
from __future__ import annotations

import copy
import math
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pipeline.errors import UsageError
from pipeline.model.build import build_system
from pipeline.study.files.documents import load_study, parse_study, study_from_document, study_to_mapping
from pipeline.model.system import natural_frequencies

ROOT = Path(__file__).resolve().parents[3]
STUDIES = ROOT / "studies"
BAD = Path(__file__).resolve().parents[2] / "bad_studies"
EXAMPLES = [STUDIES / f"paper_example{i}.toml" for i in (1, 2, 3)]
BAD_FILES = sorted(BAD.glob("*.toml"))


def expected_field(path: Path) -> str:
    return re.match(rb"# field: (.*)\n", path.read_bytes()).group(1).decode()


def needs_quick(path: Path) -> bool:
    """A corpus file whose error is in its [quick] variant says `# run: --quick`."""
    return b"\n# run: --quick\n" in path.read_bytes()[:400]


# ---------------------------------------------------------------------------
# The three paper examples (Sec. 6)
# ---------------------------------------------------------------------------

def test_example1_parameters():
    s = load_study(EXAMPLES[0])
    sysm = s.system({"preload": 2.0})
    assert (sysm.M, sysm.C, sysm.K) == ([[1.0]], [[0.3]], [[3.55e4]])
    assert sysm.contact.ku[0] == 1e4 and sysm.contact.kv[0] == 0 and sysm.contact.mu[0] == 0.5
    assert sysm.contact.n0[0] == 2.0
    assert sysm.forcing_coefficients(7)[0].tolist() == [0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    assert s.sweep.axes == {"preload": (0.0, 0.5, 1.0, 2.0, 5.0, 10.0, 1000.0)}
    assert (s.sweep.frequency.omega_start, s.sweep.frequency.omega_stop) == (150.0, 250.0)
    assert s.solver.harmonics == 7 and s.solver.force_evaluation == "exact"
    # linear limits of Fig. 2: sqrt(k/m) without, sqrt((k + ku)/m) with the damper stuck
    assert natural_frequencies(sysm, "open")[0] == pytest.approx(188.414, abs=1e-3)
    assert natural_frequencies(sysm, "stuck")[0] == pytest.approx(213.307, abs=1e-3)


def test_example2_natural_frequencies_match_paper():
    s = load_study(EXAMPLES[1])
    sysm = s.system({"preload": 100.0})
    f_free = natural_frequencies(sysm, "open") / (2 * np.pi)
    f_stuck = natural_frequencies(sysm, "stuck") / (2 * np.pi)
    np.testing.assert_allclose(f_free, [19.67, 51.50], atol=0.01)      # paper Sec. 6.2
    np.testing.assert_allclose(f_stuck, [23.52, 56.97], atol=0.01)
    assert s.sweep.frequency.unit == "Hz"
    assert s.sweep.frequency.omega_start == pytest.approx(13 * 2 * np.pi)
    assert s.sweep.axes["preload"][-1] == 1e5
    assert sysm.forcing_coefficients(5)[:, 1].tolist() == [100.0, 0.0]
    np.testing.assert_array_equal(sysm.C, [[8, -4], [-4, 4]])
    assert s.output.peak_windows == ((13.0, 38.0), (38.0, 67.0))


def test_example3_modal_matrices():
    s = load_study(EXAMPLES[2])
    sysm = s.system({"preload": 10.0})
    Phi = np.array([[0.707, 1.0], [0.707, -0.5]])
    np.testing.assert_allclose(Phi.T @ sysm.M @ Phi, np.eye(2), atol=1e-12)
    np.testing.assert_allclose(Phi.T @ sysm.K @ Phi, np.diag([1.0, 100.0]), atol=1e-10)
    np.testing.assert_allclose(Phi.T @ sysm.C @ Phi, np.diag([0.02, 0.2]), atol=1e-12)
    np.testing.assert_array_equal(sysm.Bt, [[1, 0]])
    np.testing.assert_array_equal(sysm.Bn, [[0, 1]])
    c = sysm.contact
    assert (c.ku[0], c.kv[0], c.mu[0], c.n0[0]) == (1.0, 1.0, 0.4, 10.0)
    assert sysm.forcing_coefficients(7)[:, 1].tolist() == [1.0, 1.0]
    assert s.sweep.axes["preload"] == (-100.0, -20.0, 10.0, 500.0)
    assert set(s.scene.effects) == {"friction", "normal_load_variation", "separation"}


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_quick_variant_overrides_only_what_it_names(path):
    full, quick = load_study(path), load_study(path, quick=True)
    assert quick.quick and not full.quick
    assert quick.solver.harmonics == 3 < full.solver.harmonics
    assert set(quick.sweep.axes["preload"]) < set(full.sweep.axes["preload"])
    assert quick.sweep.frequency == full.sweep.frequency
    assert quick.solver.force_evaluation == full.solver.force_evaluation


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_schema_round_trip(path):
    """file -> Study -> canonical document -> Study: the same scene, sweep, solver."""
    s = load_study(path)
    doc = study_to_mapping(s)
    t = study_from_document(copy.deepcopy(doc), file="canonical", name=s.name, text=s.text)
    assert (t.sweep, t.solver, t.output, t.title) == (s.sweep, s.solver, s.output, s.title)
    for case in (c for _, c in s.sweep.cases()):
        a, b = s.system(case), t.system(case)
        for k in ("M", "C", "K", "Bt", "Bn", "forcing"):
            np.testing.assert_allclose(getattr(a, k), getattr(b, k), rtol=1e-14, atol=1e-15)
        for k in ("ku", "kv", "mu", "n0"):
            np.testing.assert_array_equal(getattr(a.contact, k), getattr(b.contact, k))
    assert study_to_mapping(t) == doc
    # the study text stored in a dataset parses to the same study
    assert parse_study(s.text, file="x.toml").sweep == s.sweep


def test_signed_dofs_and_coefficient_rows_agree():
    base = tomllib.loads((STUDIES / "paper_example2.toml").read_text())
    base["scene"]["contact"][0]["tangential"] = ["x1", "-x2"]
    a = study_from_document(copy.deepcopy(base)).system({"preload": 1.0})
    base["scene"]["contact"][0]["tangential"] = {"x1": 1.0, "x2": -1.0}
    b = study_from_document(base).system({"preload": 1.0})
    np.testing.assert_array_equal(a.Bt, [[1.0, -1.0]])
    np.testing.assert_array_equal(a.Bt, b.Bt)


def test_build_system_applies_every_axis():
    s = load_study(EXAMPLES[2])
    sysm = build_system(s.scene, {"preload": 3.0, "mu": 0.2, "ku": 5.0, "kv": 7.0,
                                  "excitation_scale": 2.0})
    c = sysm.contact
    assert (c.n0[0], c.mu[0], c.ku[0], c.kv[0]) == (3.0, 0.2, 5.0, 7.0)
    assert sysm.forcing[:, 1].tolist() == [2.0, 2.0]
    with pytest.raises(ValueError, match="unknown axes"):
        build_system(s.scene, {"temperature": 1.0})


@pytest.mark.parametrize("method,ok", [("exact", True), ("aft", False)])
def test_samples_rule_applies_only_where_samples_are_taken(method, ok):
    """H = 150 with the default 256 samples: exact forces sample nothing and run; AFT
    needs 2H+1 = 301 samples and is refused, naming the field."""
    doc = tomllib.loads(EXAMPLES[0].read_text())
    doc["solver"] = {"harmonics": 150, "force_evaluation": method}
    if ok:
        assert study_from_document(doc, file="h150.toml").solver.harmonics == 150
    else:
        with pytest.raises(UsageError, match=r"h150.toml: solver.harmonics: must be >= 2H\+1 = 301"):
            study_from_document(doc, file="h150.toml")


def test_grid_cases_in_file_order():
    doc = tomllib.loads((STUDIES / "paper_example3.toml").read_text())
    doc["sweep"] = {"mu": [0.1, 0.2], "preload": [10.0, 20.0, 30.0],
                    "frequency": {"start": 0.5, "stop": 1.6, "unit": "rad/s"}}
    s = study_from_document(doc)
    assert s.sweep.shape == (2, 3)
    cases = s.sweep.cases()
    assert cases[0] == ((0, 0), {"mu": 0.1, "preload": 10.0})
    assert cases[-1] == ((1, 2), {"mu": 0.2, "preload": 30.0})


# ---------------------------------------------------------------------------
# The bad-study corpus: exit 2, one line `error: <file>: <field>: ...`, no output
# ---------------------------------------------------------------------------

def test_corpus_is_large_enough():
    assert len(BAD_FILES) >= 30


@pytest.mark.parametrize("path", BAD_FILES, ids=lambda p: p.stem)
def test_bad_study_is_rejected_with_its_field(path):
    field = expected_field(path)
    with pytest.raises(UsageError) as exc:
        load_study(path, quick=needs_quick(path))
    msg = str(exc.value)
    assert msg.startswith(f"{path}: {field}: "), msg
    assert "\n" not in msg and len(msg) > len(f"{path}: {field}: ") + 5


@pytest.mark.parametrize("path", [p for p in BAD_FILES if needs_quick(p)], ids=lambda p: p.stem)
def test_quick_section_is_read_only_with_quick(path):
    """A full run never depends on [quick]: the same file loads without --quick
    unless its main tables are wrong too (then that is the error reported)."""
    if expected_field(path).startswith("quick"):
        assert not load_study(path).quick
    else:
        with pytest.raises(UsageError, match=re.escape(f"{path}: {expected_field(path)}: ")):
            load_study(path)


def test_main_table_typo_is_reported_before_quick():
    path = BAD / "sweep_misspelled_key_with_quick.toml"
    for quick in (False, True):
        with pytest.raises(UsageError, match=r"sweep\.prelod: unknown key .*did you mean "
                                             r"'preload'\?$"):
            load_study(path, quick=quick)


def test_disk_full_run_ignores_an_invalid_quick_sweep():
    """12 sectors with an untouched [quick.sweep] eo = [0, 12]: the full study runs,
    only --quick is refused (with the quick field)."""
    doc = tomllib.loads((STUDIES / "disk_cyclic.toml").read_text())
    doc["scene"]["disk"]["sectors"] = 12
    doc["sweep"]["eo"] = [0, 3, 6]
    doc["quick"]["sweep"] = {"eo": [0, 12]}
    s = study_from_document(copy.deepcopy(doc), file="disk12.toml")
    assert s.sweep.axes["eo"] == (0, 3, 6) and not s.quick
    with pytest.raises(UsageError, match=r"^disk12\.toml: quick\.sweep\.eo\[1\]: "):
        study_from_document(doc, file="disk12.toml", quick=True)


@pytest.mark.parametrize("preload, ok", [(0.0, False), (-5.0, False), (1e-3, True)])
def test_varying_normal_load_that_must_separate_needs_separation(preload, ok):
    """kv > 0 with normal DOFs: a preload <= 0 separates as soon as the contact moves,
    so "separation" must be declared; a positive preload declares a closed contact."""
    doc = tomllib.loads((STUDIES / "paper_example3.toml").read_text())
    doc["scene"]["effects"] = ["friction", "normal_load_variation"]
    doc["sweep"]["preload"] = [preload, 500.0]
    doc.pop("quick")
    doc["output"].pop("optimum_preload")
    if ok:
        assert study_from_document(doc, file="e3.toml").scene.effects == (
            "friction", "normal_load_variation")
    else:
        with pytest.raises(UsageError, match=r"^e3\.toml: scene\.effects: .*declare \"separation\""):
            study_from_document(doc, file="e3.toml")


def _cli_has_run():
    from pipeline.__main__ import build_parser

    try:
        build_parser().parse_args(["run", "x.toml"])
        return True
    except SystemExit:
        return False


CLI_SAMPLE = ["syntax_unterminated_string", "encoding_latin1", "contact_negative_mu",
              "sweep_empty_preload", "frequency_equal_bounds", "scene_unknown_key"]


@pytest.mark.parametrize("entry", ["pipeline.study.execution.run", "pipeline run"])
@pytest.mark.parametrize("stem", CLI_SAMPLE)
def test_cli_reports_one_line_and_writes_nothing(tmp_path, stem, entry):
    if entry == "pipeline run" and not _cli_has_run():
        pytest.skip("`run` is not wired into pipeline/__main__.py yet")
    path = BAD / f"{stem}.toml"
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", *entry.split(), str(path), "--out", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith(f"error: {path}: {expected_field(path)}: ")
    assert "Traceback" not in r.stderr and r.stdout == ""
    assert not out.exists()


def test_missing_file_is_a_usage_error(tmp_path):
    with pytest.raises(UsageError, match=r"nope\.toml: \(file\): no such file"):
        load_study(tmp_path / "nope.toml")


def test_a_dataset_or_figure_given_as_a_study_is_named_for_what_it_is(tmp_path):
    """A netCDF dataset (classic or netCDF-4) or a figure passed where a study file goes:
    one line saying what the file is, pointing to `check` for a dataset."""
    import xarray as xr

    ds = xr.Dataset({"a": ("x", [1.0, 2.0])})
    ds.to_netcdf(tmp_path / "r4.nc", engine="netcdf4")
    ds.to_netcdf(tmp_path / "r3.nc", engine="netcdf4", format="NETCDF3_64BIT")
    (tmp_path / "f.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    for name, kind in (("r4.nc", "a netCDF-4 dataset"), ("r3.nc", "a netCDF dataset"),
                       ("f.png", "a PNG image")):
        with pytest.raises(UsageError) as exc:
            load_study(tmp_path / name)
        assert str(exc.value).startswith(f"{tmp_path / name}: (file): {kind}, not a study file")
        assert ("`check` reads a dataset" in str(exc.value)) == name.endswith(".nc")


# ---------------------------------------------------------------------------
# Fuzz: the loader raises UsageError and nothing else
# ---------------------------------------------------------------------------

VALID_DOCS = [tomllib.loads(p.read_text()) for p in EXAMPLES]

scalars = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(10**30), max_value=10**30),
    st.sampled_from([0, 1, -1, 2, 3, 10**400]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-300, 1e300, -1.0, 0.5, 1e5]),
    st.text(max_size=12),
    st.sampled_from(["x", "x1", "-x1", "u", "v", "Hz", "rad/s", "exact", "aft", "friction",
                     "separation", "lumped", "disk", "", "linear", "log"]),
)
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)),
    max_leaves=10)


def _paths(doc, prefix=()):
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _paths(v, prefix + (i,))


def _mutate(doc, path, op, value):
    if not path:
        return value if op == "replace" else doc
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    key = path[-1]
    if op == "replace":
        parent[key] = value
    elif op == "delete":
        del parent[key]
    elif op == "add" and isinstance(parent[key], dict):
        parent[key]["zz_extra" if value is None else str(value)[:8]] = value
    elif op == "add" and isinstance(parent[key], list):
        parent[key].append(value)
    return doc


def _loads_or_usage_error(doc):
    try:
        s = study_from_document(doc, file="fuzz.toml")
    except UsageError as exc:
        msg = str(exc)
        assert msg.startswith("fuzz.toml: ") and "\n" not in msg
        return
    for _, case in s.sweep.cases():    # a study that loads builds a System for every case
        s.system(case)


@settings(max_examples=300, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_fuzz_mutated_documents(data):
    doc = copy.deepcopy(data.draw(st.sampled_from(VALID_DOCS)))
    for _ in range(data.draw(st.integers(1, 3))):
        paths = list(_paths(doc))
        path = data.draw(st.sampled_from(paths))
        op = data.draw(st.sampled_from(["replace", "delete", "add"]))
        doc = _mutate(doc, path, op, data.draw(values))
    _loads_or_usage_error(doc)


@settings(max_examples=200, deadline=None, database=None)
@given(text=st.one_of(st.text(max_size=200), st.binary(max_size=200),
                      st.builds(lambda t, k, v: t + f"\n{k} = {v}\n",
                                st.sampled_from([p.read_text() for p in EXAMPLES]),
                                st.sampled_from(["harmonics", "mu", "x", "[sweep]", "preload"]),
                                st.sampled_from(["1", "-1", "nan", "inf", "[]", "{}", '"a"', "1e999"]))))
def test_fuzz_raw_text(text):
    try:
        parse_study(text, file="fuzz.toml")
    except UsageError as exc:
        assert str(exc).startswith("fuzz.toml: ")


def test_huge_integer_is_a_usage_error():
    doc = copy.deepcopy(VALID_DOCS[0])
    doc["scene"]["contact"][0]["ku"] = 10**400
    with pytest.raises(UsageError, match=r"scene\.contact\[0\]\.ku: number too large"):
        study_from_document(doc, file="f")
    assert math.isinf(float("inf"))


@pytest.mark.parametrize("name, line", [
    ("disk_eo_not_below_sectors", "sweep.eo[1]: engine order 24 is not smaller than the "
     "number of sectors 24 (EO and EO mod N are the same excitation); give 0 <= EO <= 12"),
    ("disk_mistuning_not_declared", "scene.effects: [scene.disk] mistuning breaks cyclic "
     "symmetry: declare \"mistuning\""),
])
def test_disk_errors_read_as_one_full_line(tmp_path, name, line):
    """The corpus checks the field of every bad study; these check whole messages."""
    bad = BAD / f"{name}.toml"
    r = subprocess.run([sys.executable, "-m", "pipeline", "run", str(bad), "--out",
                        str(tmp_path / "out")], capture_output=True, text=True, cwd=ROOT,
                       timeout=120)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.splitlines() == [f"error: {bad}: {line}"]
    assert not (tmp_path / "out").exists()


def test_a_frictionless_contact_with_a_varying_normal_load_is_a_model():
    """mu = 0 is refused only where the contact would exert no force (a constant normal
    load: tests/bad_studies/contact_mu_zero_constant_load.toml); with normal DOFs and kv
    > 0 it is a unilateral normal spring, accepted."""
    text = (ROOT / "studies" / "paper_example3.toml").read_text()
    text, n = re.subn(r"(?m)^mu = 0\.4", "mu = 0.0", text)
    assert n == 1
    study = parse_study(text, file="frictionless.toml")
    assert study.scene.contacts[0].mu == 0.0 and study.scene.contacts[0].kv > 0
    # the normal load varies through a kv sweep (the contact's own kv 0): a model too
    swept = re.sub(r"(?m)^kv = 1\.0 .*$", "kv = 0.0", text).replace(
        "[sweep]\n", "[sweep]\nkv = [0.5, 1.0]\n", 1)
    assert "kv = [0.5, 1.0]" in swept and "kv = 0.0" in swept
    assert parse_study(swept, file="swept.toml").sweep.axes["kv"] == (0.5, 1.0)
