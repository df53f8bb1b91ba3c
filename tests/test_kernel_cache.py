"""Where the compiled kernels are cached (pipeline/__init__.py): one folder per machine
and kernel version, found by every process; an edit of any kernel file gives a new
folder (so no caller keeps old code); a NUMBA_CACHE_DIR of one's own wins."""
import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

import pipeline

PACKAGE = Path(pipeline.__file__).resolve().parent
PRINT_DIR = "import os, pipeline; print(os.environ['NUMBA_CACHE_DIR'])"


def _python(code, env, cwd):
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, cwd=cwd, check=True, timeout=300)
    return out.stdout.strip()


def _env(tmp_path, **extra):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH")}
    return {**env, "XDG_CACHE_HOME": str(tmp_path / "cache"), **extra}


def test_every_module_that_compiles_is_a_kernel_module():
    uses = set()
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            if any(n.split(".")[0] == "numba" for n in names):
                uses.add(path.relative_to(PACKAGE).as_posix())
    assert uses == set(pipeline.KERNEL_MODULES)


def test_kernels_are_cached_in_one_folder_per_kernel_version(tmp_path):
    """A copy of the package: its kernels cache under the user's cache folder, the same
    folder for every process; one character added to one kernel file: another."""
    copy = tmp_path / "src"
    shutil.copytree(PACKAGE, copy / "pipeline", ignore=shutil.ignore_patterns("__pycache__"))
    env = _env(tmp_path)
    first = _python(PRINT_DIR, env, copy)
    assert Path(first).parent == tmp_path / "cache" / "shroud-pipeline"
    assert _python(PRINT_DIR, env, copy) == first
    compile_one = ("import numpy as np, pipeline.fourier.trigkernel as t\n"
                   "print(t.eval012(np.array([1.0, 2.0, 0.5]), 1, 0.3)[0])")
    value = float(_python(compile_one, env, copy))
    assert abs(value - (1.0 + 2.0 * np.cos(0.3) + 0.5 * np.sin(0.3))) < 1e-14
    assert list(Path(first).rglob("trigkernel.eval012-*.nbi"))     # cached there
    kernel = copy / "pipeline" / "fourier" / "trigkernel.py"
    kernel.write_text(kernel.read_text() + "\n# edited\n")
    assert _python(PRINT_DIR, env, copy) != first
    own = str(tmp_path / "mine")
    assert _python(PRINT_DIR, {**env, "NUMBA_CACHE_DIR": own}, copy) == own

