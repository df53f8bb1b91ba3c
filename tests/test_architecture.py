"""The package's own import structure, read from its source with `ast`.

Every `import` and `from ... import` of `pipeline` counts, at module level and inside
functions, relative and absolute.  Asserted: no private name (leading underscore) is
imported from another module, no import circle anywhere, imports flow one way along
the data path.  Sizes are advisory, never asserted: modules are cut where their
concepts are, and `test_sizes_are_advisory` prints (with `pytest -s`) the modules
over ADVISORY_MODULE lines, the functions over ADVISORY_FUNCTION and the folders over
ADVISORY_FOLDER modules, as places to look at, not failures.
"""
import ast
import functools
from collections import defaultdict
from pathlib import Path

import pipeline

PACKAGE = Path(pipeline.__file__).resolve().parent
TESTS = Path(__file__).resolve().parent


@functools.lru_cache(maxsize=None)
def parse(path: Path) -> ast.Module:
    """The syntax tree of one file, parsed once for all the tests here (read only)."""
    return ast.parse(path.read_text(encoding="utf-8"))



def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def absolute(current: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The module a `from ... import` names, relative levels resolved."""
    if node.level == 0:
        return node.module or ""
    base = current.split(".")
    if not is_package:
        base = base[:-1]
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports(path: Path, name: str):
    """(imported module, imported name or None, line, at module level) of one file."""
    tree = parse(path)
    top = {id(n) for n in tree.body}
    is_package = path.name == "__init__.py"
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, None, node.lineno, id(node) in top
        elif isinstance(node, ast.ImportFrom):
            target = absolute(name, is_package, node)
            for a in node.names:
                yield target, a.name, node.lineno, id(node) in top


def is_private(name) -> bool:
    return bool(name) and name.startswith("_") and not name.startswith("__")


def scan(root: Path = PACKAGE):
    files = {module_name(f, root): f for f in sorted(root.rglob("*.py"))}
    edges, private = defaultdict(set), []
    for mod, path in files.items():
        for target, name, line, _ in imports(path, mod):
            hit = [m for m in (target, f"{target}.{name}") if m in files and m != mod]
            # a package's __init__ importing its own submodules is no circle of design
            edges[mod].update(m for m in hit
                              if not (path.name == "__init__.py" and m.startswith(mod + ".")))
            if target in files and target != mod and is_private(name):
                private.append(f"{path.relative_to(root.parent)}:{line} imports {target}.{name}")
    return files, edges, private


def circles(nodes, edges):
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(comp)

    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return out


def largest_units(files, n=5):
    """The n longest modules and the n longest functions/classes, as text."""
    sizes, units = [], []
    for mod, path in files.items():
        text = path.read_text(encoding="utf-8")
        sizes.append((len(text.splitlines()), mod))
        for node in ast.walk(parse(path)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                units.append((node.end_lineno - node.lineno + 1,
                              f"{path.relative_to(PACKAGE.parent)}:{node.lineno} {node.name}"))
    mods = ", ".join(f"{m} {k}" for k, m in sorted(sizes, reverse=True)[:n])
    funcs = "; ".join(f"{u} ({k} lines)" for k, u in sorted(units, reverse=True)[:n])
    return f"largest modules: {mods}\nlargest functions/classes: {funcs}"


def report() -> str:
    files, edges, private = scan()
    lines = [f"{len(files)} modules", f"import circles: {len(circles(files, edges))}"]
    lines += ["  - " + ", ".join(sorted(c)) for c in circles(files, edges)]
    lines += [f"private names imported across modules: {len(private)}"]
    lines += ["  - " + p for p in private]
    (k, m), (kf, f) = (sizes[0] for sizes in unit_sizes())
    sizes = f"pipeline: largest module {m} ({k} lines), largest function {f} ({kf} lines)"
    return "\n".join(lines + [largest_units(files), sizes])


def test_no_private_name_is_imported_across_modules():
    _, _, private = scan()
    assert not private, ("a private name is imported from another module: make it public "
                         "(clear name, docstring) or move it\n" + report())


def test_contact_modules_form_no_circle():
    files, edges, _ = scan()
    contact = {m for m in files if m == "pipeline.contact" or m.startswith("pipeline.contact.")}
    assert {"pipeline.contact", "pipeline.contact.exact", "pipeline.contact.aft"} <= contact
    tangled = [c for c in circles(files, edges) if c & contact]
    assert not tangled, "the contact modules import each other in a circle\n" + report()


def test_no_import_circle():
    """Module-level and deferred imports together form no circle anywhere."""
    files, edges, _ = scan()
    found = circles(files, edges)
    assert not found, f"import circles: {[sorted(c) for c in found]}\n" + report()


DATA_PATH = ("fourier", "contact", "structure", "model", "solve", "study", "bench")


def stage(module: str) -> int:
    """Position of a module's folder on the data path; top-level modules (errors,
    paper_systems, the CLI) rank by what they are: errors first, the CLI last."""
    parts = module.split(".")
    if len(parts) >= 2 and parts[1] in DATA_PATH:
        return DATA_PATH.index(parts[1])
    return {"pipeline.errors": -1, "pipeline": -1, "pipeline.paper_systems": 3.5}.get(
        module, len(DATA_PATH))


def test_imports_flow_one_way_along_the_data_path():
    """fourier -> contact -> structure -> model -> solve -> study -> bench / CLI: no
    module imports from a folder further down the path (deferred imports included)."""
    files, edges, _ = scan()
    back = sorted(f"{m} imports {t}" for m in files for t in edges[m] if stage(t) > stage(m))
    assert not back, "imports against the data path:\n" + "\n".join(back)


def test_tests_use_public_names_and_no_other_test_module():
    found = []
    for path in sorted(TESTS.rglob("*.py")):
        for target, name, line, _ in imports(path, path.stem):
            where = f"{path.name}:{line}"
            if target.split(".")[0] == "pipeline" and is_private(name):
                found.append(f"{where} imports the private {target}.{name}")
            if target.split(".")[-1].startswith("test_") or (target in ("tests", "")
                                                            and (name or "").startswith("test_")):
                found.append(f"{where} imports from the test module {target}")
    assert not found, "\n".join(found)


ADVISORY_MODULE = 500    # lines of one module in pipeline/: printed above, never failed
ADVISORY_FUNCTION = 80   # lines of one function or method there (decorators aside)
ADVISORY_FOLDER = 12     # modules of one folder of pipeline/ (its __init__ aside)


def unit_sizes():
    """([(lines, module)], [(lines, "path:line name")]) of the modules and of the
    functions and methods in pipeline/, largest first."""
    modules, functions = [], []
    for path in sorted(PACKAGE.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        where = path.relative_to(PACKAGE.parent)
        modules.append((len(text.splitlines()), str(where)))
        for node in ast.walk(parse(path)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                functions.append((node.end_lineno - node.lineno + 1,
                                  f"{where}:{node.lineno} {node.name}"))
    return sorted(modules, reverse=True), sorted(functions, reverse=True)


def folder_sizes():
    """[(modules, folder)] of the folders of pipeline/ (each __init__ aside), largest first."""
    out = []
    for d in sorted(p for p in PACKAGE.rglob("*") if p.is_dir() and p.name != "__pycache__"):
        mods = [f for f in d.glob("*.py") if f.name != "__init__.py"]
        out.append((len(mods), str(d.relative_to(PACKAGE.parent))))
    return sorted(out, reverse=True)


def advisory_sizes() -> str:
    """The units over their advisory size, largest first, as text."""
    modules, functions = unit_sizes()
    lines = [f"modules over {ADVISORY_MODULE} lines: "
             + (", ".join(f"{m} ({k})" for k, m in modules if k > ADVISORY_MODULE) or "none"),
             f"functions over {ADVISORY_FUNCTION} lines: "
             + ("; ".join(f"{u} ({k})" for k, u in functions if k > ADVISORY_FUNCTION) or "none"),
             f"folders over {ADVISORY_FOLDER} modules: "
             + (", ".join(f"{d} ({k})" for k, d in folder_sizes() if k > ADVISORY_FOLDER)
                or "none")]
    return "\n".join(lines)


def test_sizes_are_advisory():
    """Not a check: module, function and folder sizes over their advisory size, shown
    with `pytest -s` (or -rP).  Modules are cut where their concepts are; a size is a
    hint to look, not a reason to cut."""
    print("\n" + advisory_sizes())


def test_structure_summary():
    """Not a check: the report, shown with `pytest -s` (or -rP)."""
    print("\n" + report())


KERNEL_FOLDER = "pipeline/solve/harmonic_balance/"
KERNEL = KERNEL_FOLDER + "dynamic_stiffness.py"   # where the criterion must find it
# Modules upstream of `solve` on the data path that cannot import the kernel, each with
# its own (non-HBM) use: the receptance of a reduced blade model, checked against the
# full model's in the structure folder.
DYNAMIC_STIFFNESS_ELSEWHERE = {"pipeline/structure/reduction.py": "frf"}


def _mentions(node, name: str) -> bool:
    return any((isinstance(n, ast.Name) and n.id == name)
               or (isinstance(n, ast.Attribute) and n.attr == name) for n in ast.walk(node))


def _squared(node) -> bool:
    """A square in the expression: `x ** 2` or `x * x` (the same sub-expression twice)."""
    for n in ast.walk(node):
        if isinstance(n, ast.BinOp) and isinstance(n.op, ast.Pow) and \
                isinstance(n.right, ast.Constant) and n.right.value == 2:
            return True
        if isinstance(n, ast.BinOp) and isinstance(n.op, ast.Mult) and \
                ast.dump(n.left) == ast.dump(n.right):
            return True
    return False


def _imaginary(node) -> bool:
    return any(isinstance(n, ast.Constant) and isinstance(n.value, complex)
               for n in ast.walk(node))


def dynamic_stiffness_terms(path: Path):
    """(line, function, text) of every product, in one module, of an expression that
    names the mass matrix `M` (a name or an attribute `.M`) with one that holds a
    square (`x ** 2`, `x * x`), or of one that names the damping matrix `C` with one
    that holds an imaginary literal (`1j`): the -(h Om)^2 M and i h Om C of a dynamic
    stiffness, in whatever layout or spelling (`w * w * M`, `Om**2 * (M @ Q)`,
    `(Om**2 * h2) * M`, `1j * h * Om * C`)."""
    tree = parse(path)
    where = {}
    for f in ast.walk(tree):
        if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for n in ast.walk(f):
                where.setdefault(id(n), f.name)
    for n in ast.walk(tree):
        if not (isinstance(n, ast.BinOp) and isinstance(n.op, ast.Mult)):
            continue
        for a, b in ((n.left, n.right), (n.right, n.left)):
            if (_mentions(a, "M") and _squared(b)) or (_mentions(a, "C") and _imaginary(b)):
                yield n.lineno, where.get(id(n)), ast.unparse(n)
                break


def test_dynamic_stiffness_is_formed_in_one_folder():
    """The harmonic dynamic stiffness K - (h Om)^2 M + i h Om C (and its real layout
    K (x) I + Om C (x) D + Om^2 M (x) D^2) is formed in `solve/harmonic_balance/` only
    (today in its `dynamic_stiffness.py`; a new solve strategy may be a module of its
    own there), so that an added linear term enters in one folder.

    Criterion (`dynamic_stiffness_terms`, read with `ast`): no product of an expression
    naming `M` with a squared one, and no product of an expression naming `C` with an
    imaginary literal, in any module of the package outside that folder.  Exempt, by
    module and function: DYNAMIC_STIFFNESS_ELSEWHERE (upstream of `solve`, so unable
    to import it).  Not caught: a frequency squared under another name (an eigenvalue
    shift s = w^2 in K - s M, which is an eigen-problem, not a dynamic stiffness)."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).as_posix()
        if rel.startswith(KERNEL_FOLDER):
            continue
        for line, func, text in dynamic_stiffness_terms(path):
            if DYNAMIC_STIFFNESS_ELSEWHERE.get(rel) != func:
                found.append(f"{rel}:{line} ({func}) {text}")
    assert not found, ("the dynamic stiffness is formed outside "
                       f"{KERNEL_FOLDER} (call it instead):\n" + "\n".join(found))
    kernel = list(dynamic_stiffness_terms(PACKAGE.parent / KERNEL))
    assert kernel, "the criterion finds no dynamic stiffness in the kernel itself"


# The registry of study kinds and the one module allowed to compare a value with a
# kind's name; dataset_check reads the `kind` attribute of a netCDF file (the dataset
# contract of a file, whatever wrote it), not a study.
KIND_REGISTRY = "pipeline/study/kinds.py"
KIND_ATTRIBUTE_READERS = ("pipeline/study/datasets/conformance.py",)


def kind_comparisons(path: Path, names) -> list:
    """Lines of `path` that compare a value with a study kind's name: `x == "modes"`,
    `x != "response"`, `x in ("disk_modes", ...)`, or look a value up in a table keyed
    by kind names (`{"modes": f, ...}[x]`).  A name on the left of `in` (`"modes" in
    data`: is there a [modes] table) looks a key up and is no dispatch."""
    found = []
    for node in ast.walk(parse(path)):
        if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Dict):
            found += [f"{path.relative_to(PACKAGE.parent)}:{node.lineno} looks up {k.value!r}"
                      for k in node.value.keys
                      if isinstance(k, ast.Constant) and k.value in names]
        if not isinstance(node, ast.Compare):
            continue
        operands = [node.left, *node.comparators]
        for op, a, b in zip(node.ops, operands, operands[1:]):
            sides = (b,) if isinstance(op, (ast.In, ast.NotIn)) else (a, b)
            words = [e.value for s in sides
                     for e in (s.elts if isinstance(s, (ast.Tuple, ast.List, ast.Set)) else (s,))
                     if isinstance(e, ast.Constant) and e.value in names]
            found += [f"{path.relative_to(PACKAGE.parent)}:{node.lineno} compares with {w!r}"
                      for w in words]
    return found


def test_study_kinds_are_dispatched_in_one_place():
    """A study's kind ("response", "modes", "disk_modes", "accuracy_cost": the names and
    `[study] kind` words of the registry's entries) is compared with nothing outside
    the registry module `study/kinds.py`: documents, run, check and bench estimate
    reach a kind through its entry, and every entry comes from the kind's own module."""
    from pipeline.study import kinds

    names = {k.name for k in kinds.KINDS} | {k.word for k in kinds.KINDS}
    assert {"response", "modes", "disk_modes", "accuracy_cost"} <= names
    skip = {KIND_REGISTRY, *KIND_ATTRIBUTE_READERS}
    found = [line for path in sorted(PACKAGE.rglob("*.py"))
             if str(path.relative_to(PACKAGE.parent)) not in skip
             for line in kind_comparisons(path, names)]
    assert not found, "study kinds dispatched outside the registry:\n" + "\n".join(found)
    assert len({k.name for k in kinds.KINDS}) == len(kinds.KINDS)


# Where the Yang-Menq element may be named: the contact layer, the study layer (study
# files, their scenes, and the law-specific outputs: hysteresis loops and contact
# states), the paper's systems (declared data) and the contact element's benchmark.
# The solvers, the structures and the model (scenes become elements through
# `contact.registry.friction_elements`) reach the elements through `contact.laws` and
# `contact.registry`.
YANG_MENQ_NAMED_IN = ("pipeline/contact/", "pipeline/study/", "pipeline/paper_systems.py",
                      "pipeline/bench/")


def law_names(path: Path, prefix: str = "YangMenq") -> list:
    """Lines of `path` that name a class starting with `prefix` (as a name, an
    attribute or an imported name); prose in docstrings does not count."""
    found = []
    for node in ast.walk(parse(path)):
        names = ([a.name for a in node.names] if isinstance(node, (ast.Import, ast.ImportFrom))
                 else [node.id] if isinstance(node, ast.Name)
                 else [node.attr] if isinstance(node, ast.Attribute) else [])
        found += [f"{path.relative_to(PACKAGE.parent)}:{node.lineno} names {n}"
                  for n in names if n.startswith(prefix)]
    return found


def test_yang_menq_is_named_only_in_the_contact_and_study_layers():
    """The harmonic balance, continuation, stability, time integration, the structures
    and the generic model (`System`, cyclic assembly, static load) never name the
    Yang-Menq element: they hold `contact.laws.ContactElements` and evaluate them through
    the law `contact.registry.law_of` returns, so a second law plugs in beside it."""
    found = [line for path in sorted(PACKAGE.rglob("*.py"))
             if not str(path.relative_to(PACKAGE.parent)).startswith(YANG_MENQ_NAMED_IN)
             for line in law_names(path)]
    assert not found, "Yang-Menq named outside its layers:\n" + "\n".join(found)
    assert law_names(PACKAGE / "solve" / "harmonic_balance" / "hbm.py") == []
    assert law_names(PACKAGE / "contact" / "registry.py")   # the scan sees names


def test_tests_mirror_the_package():
    """Every test module sits in the folder of the package part it tests (tests/solve/
    for pipeline/solve/, ...); only the whole-package tests sit at tests/."""
    parts = {str(d.relative_to(PACKAGE)) for d in PACKAGE.rglob("*")
             if d.is_dir() and d.name != "__pycache__"}
    for path in TESTS.rglob("test_*.py"):
        where = str(path.parent.relative_to(TESTS))
        assert where == "." or where in parts, f"{path.relative_to(TESTS)}: no pipeline/{where}"
