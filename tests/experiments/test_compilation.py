"""Loading numba's on-disk cache into a process (the local runner's worker does it before forking each cell)."""

import subprocess
import sys
import textwrap

KERNEL = """
from numba import njit


@njit(cache=True)
def twice(x):
    return 2.0 * x
"""

SECOND_PROCESS = """
import kernelmod
from slamarena.experiments.compilation import CompileClock, load_cached_kernels

loaded = load_cached_kernels(prefix="kernelmod")
again = load_cached_kernels(prefix="kernelmod")
with CompileClock() as clock:
    value = kernelmod.twice(3.0)
print(loaded, again, len(kernelmod.twice.overloads), clock.seconds, value)
"""


def _python(code: str, tmp_path) -> str:
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(tmp_path), "PATH": "/usr/bin:/bin"}
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


def test_a_fresh_process_loads_the_cached_kernel_before_its_first_call_and_then_compiles_nothing(tmp_path):
    (tmp_path / "kernelmod.py").write_text(KERNEL)
    assert _python(
        "from slamarena.experiments.compilation import load_cached_kernels as f; import kernelmod;"
        "print(f(prefix='kernelmod'))",
        tmp_path,
    ) == ["0"]  # nothing cached yet
    _python("import kernelmod; kernelmod.twice(1.0)", tmp_path)  # compiles, into the cache
    loaded, again, overloads, compile_s, value = _python(SECOND_PROCESS, tmp_path)
    assert (loaded, again, overloads) == ("1", "0", "1")  # loaded once, the second call finds it loaded
    assert float(compile_s) == 0.0 and float(value) == 6.0  # the call used the loaded code


def test_an_entry_for_other_bytecode_is_not_loaded(tmp_path):
    (tmp_path / "kernelmod.py").write_text(KERNEL)
    _python("import kernelmod; kernelmod.twice(1.0)", tmp_path)
    (tmp_path / "kernelmod.py").write_text(KERNEL.replace("2.0 * x", "3.0 * x"))  # the source changed since
    assert _python(
        "from slamarena.experiments.compilation import load_cached_kernels as f; import kernelmod;"
        "print(f(prefix='kernelmod'), len(kernelmod.twice.overloads))",
        tmp_path,
    ) == ["0", "0"]
