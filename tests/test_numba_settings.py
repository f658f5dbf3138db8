"""The package's numba settings (ffsm_pin/_numba_cache.py): chosen when the user has not set
them, the user's own values win, and both are in place before numba reads its configuration."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

PROBE = (
    "import ffsm_pin, json, os\n"
    "from numba.core import config\n"
    "print(json.dumps({'opt': int(config.OPT), 'loop_vectorize': int(config.LOOP_VECTORIZE),"
    " 'cache': os.environ.get('NUMBA_CACHE_DIR')}))\n"
)


def _probe(**env_changes: str | None) -> dict:
    env = dict(os.environ)
    for key in ("NUMBA_OPT", "NUMBA_LOOP_VECTORIZE"):
        env.pop(key, None)
    for key, value in env_changes.items():
        if value is None:
            env.pop(key, None)
        else:
            env[key] = value
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True,
                         check=True)  # fmt: skip
    return json.loads(out.stdout)


def test_package_settings_apply_before_numba_loads():
    got = _probe()
    assert (got["opt"], got["loop_vectorize"]) == (2, 0)


@pytest.mark.parametrize(("key", "value", "field", "expected"), [
    ("NUMBA_OPT", "3", "opt", 3),
    ("NUMBA_LOOP_VECTORIZE", "1", "loop_vectorize", 1),
    ("NUMBA_CACHE_DIR", "/tmp/ffsm-pin-probe-cache", "cache", "/tmp/ffsm-pin-probe-cache"),
])  # fmt: skip
def test_the_users_numba_settings_win(key, value, field, expected):
    assert _probe(**{key: value})[field] == expected


# ---------------------------------------------------------------- the cache folder's name
def _copy_package(tmp_path):
    from ffsm_pin import _numba_cache

    tree = tmp_path / "ffsm_pin"
    shutil.copytree(_numba_cache.PACKAGE, tree, ignore=shutil.ignore_patterns("__pycache__"))
    return tree


def test_an_edited_kernel_source_gets_its_own_cache_folder(tmp_path):
    """numba checks only the file of the function it loads: the control period
    (control/period.py) cached with the spatial kernels of control/fast_spatial.py inside would
    be loaded again after an edit of fast_spatial.py alone. The folder's name follows every
    kernel source, so the edited tree compiles anew; a comment or docstring edit of a module
    without kernels does not (the CLI's text, say)."""
    from ffsm_pin._numba_cache import PACKAGE, kernel_digest

    tree = _copy_package(tmp_path)
    assert kernel_digest(tree) == kernel_digest(PACKAGE)  # the same sources, another folder
    before = kernel_digest(tree)
    callee = tree / "control" / "fast_spatial.py"
    callee.write_text(callee.read_text() + "\n# an edit of a kernel module\n")
    assert kernel_digest(tree) != before
    after = kernel_digest(tree)
    cli = tree / "sim" / "cli.py"
    assert b"numba" not in cli.read_bytes()
    cli.write_text(cli.read_text() + "\n# an edit of a module without kernels\n")
    assert kernel_digest(tree) == after


def test_the_cache_folder_is_per_source_and_old_folders_are_pruned(tmp_path):
    from ffsm_pin._numba_cache import PRUNE_AFTER_DAYS, kernel_digest, numba_cache_dir

    env = dict(os.environ)
    try:
        os.environ["XDG_CACHE_HOME"] = str(tmp_path / "xdg")
        parent = tmp_path / "xdg" / "ffsm-pin" / "numba"
        parent.mkdir(parents=True)
        old, recent = parent / "0123456789abcdef", parent / "fedcba9876543210"
        for folder in (old, recent):
            (folder / "control_x").mkdir(parents=True)
        stamp = time.time() - (PRUNE_AFTER_DAYS + 1) * 86400
        os.utime(old, (stamp, stamp))
        tree = _copy_package(tmp_path)
        got = numba_cache_dir(tree)
        assert got == str(parent / kernel_digest(tree))
        assert not old.exists() and recent.exists()  # unused for a month: removed
        os.utime(got, (stamp, stamp))
        assert numba_cache_dir(tree) == got and time.time() - os.stat(got).st_mtime < 60
    finally:
        os.environ.clear()
        os.environ.update(env)


# ------------------------------------------- one cache whatever folder the package is in
PLACES = (
    "import ffsm_pin, hashlib, json, sys\n"
    "from pathlib import Path\n"
    "from numba.core import caching\n"
    "from ffsm_pin import _numba_cache as m, _array_kernels as a\n"
    "from ffsm_pin.control import period\n"
    "sys.path.insert(0, sys.argv[1])\n"
    "import outside\n"
    "impl = getattr(caching, 'CacheImpl', None) or caching._CacheImpl\n"
    "k = period.period_of\n"
    "print(json.dumps({'package': m.PACKAGE.as_posix(), 'cache': m.CACHE_DIR,\n"
    "  'first': m.LOCATOR is not None and impl._locator_classes[0] is m.LOCATOR,\n"
    "  'period': k._cache.cache_path, 'put': a.put._cache.cache_path,\n"
    "  'stamp': str(k._cache._cache_file._source_stamp),\n"
    "  'digest': hashlib.sha256(Path(k.py_func.__code__.co_filename).read_bytes()).hexdigest(),\n"
    "  'outside': outside.f._cache.cache_path,\n"
    "  'note': m.cache_folder(m.PACKAGE / 'control' / 'fast.py').as_posix()}))\n"
)


def _copy_installed(tmp_path, name):
    """The package as pip installs it (``urdf/`` as ``ffsm_pin/urdf``), in ``tmp_path/name``."""
    from ffsm_pin import _numba_cache

    site = tmp_path / name
    shutil.copytree(_numba_cache.PACKAGE, site / "ffsm_pin",
                    ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
    shutil.copytree(_numba_cache.PACKAGE.parent / "urdf", site / "ffsm_pin" / "urdf",
                    ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
    return site


def _in_copy(site, xdg, code, *args, hide="", numba_cache_dir=None):
    """Run ``code`` in a Python importing the package from ``site`` (working folder: site's
    parent), with the package's cache under ``xdg``; ``hide``: a name to remove from
    ``numba.core.caching`` as it loads (another numba version)."""
    env = {**os.environ, "PYTHONPATH": str(site), "XDG_CACHE_HOME": str(xdg)}
    env.pop("NUMBA_CACHE_DIR", None)
    if numba_cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = str(numba_cache_dir)
    if hide:
        code = (
            "import importlib.abc, importlib.machinery, sys\n"
            "class Hide(importlib.abc.MetaPathFinder):\n"
            "    def find_spec(self, name, path=None, target=None):\n"
            "        if name != 'numba.core.caching':\n"
            "            return None\n"
            "        spec = importlib.machinery.PathFinder.find_spec(name, path)\n"
            "        run = spec.loader.exec_module\n"
            "        def exec_module(module):\n"
            "            run(module)\n"
            f"            delattr(module, {hide!r})\n"
            "        spec.loader.exec_module = exec_module\n"
            "        return spec\n"
            "sys.meta_path.insert(0, Hide())\n"
        ) + code
    proc = subprocess.run([sys.executable, "-c", code, *map(str, args)], cwd=site.parent,
                          env=env, capture_output=True, text=True)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return proc


def test_the_package_kernels_are_cached_by_module_path_with_a_content_stamp(tmp_path):
    """The package's locator (first in numba's list): ``<cache>/control/period`` for the
    period, whatever folder the package is in, stamped with the sha256 of the file's bytes;
    another package's kernel keeps numba's layout (a folder per absolute source folder)."""
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "outside.py").write_text(
        "from numba import njit\n@njit(cache=True)\ndef f(x):\n    return x\n"
    )
    site = _copy_installed(tmp_path, "site")
    got = json.loads(_in_copy(site, tmp_path / "xdg", PLACES, tmp_path / "elsewhere").stdout)
    cache = got["cache"]
    assert got["package"] == (site / "ffsm_pin").resolve().as_posix()  # the copy, not the tree
    assert cache.startswith(str(tmp_path / "xdg" / "ffsm-pin" / "numba"))
    assert got["first"]
    assert got["period"] == os.path.join(cache, "control", "period")
    assert got["put"] == os.path.join(cache, "_array_kernels")
    assert got["stamp"] == got["digest"]
    assert os.path.dirname(got["outside"]) == cache
    assert os.path.basename(got["outside"]).startswith("elsewhere_")
    assert got["note"] == os.path.join(cache, "control", "fast")  # the compile note looks there


def test_without_numbas_private_names_numbas_own_locators_apply(tmp_path):
    """Another numba version, without ``_CacheLocator``: nothing said, numba's layout."""
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "outside.py").write_text("")
    site = _copy_installed(tmp_path, "site")
    code = PLACES.replace("import outside\n", "").replace("outside.f._cache.cache_path", "''")
    proc = _in_copy(site, tmp_path / "xdg", code, tmp_path / "elsewhere", hide="_CacheLocator")
    got = json.loads(proc.stdout)
    assert not got["first"] and proc.stderr == ""
    control = (site / "ffsm_pin" / "control").resolve()
    numbas = f"control_{hashlib.sha1(str(control).encode()).hexdigest()}"
    assert got["period"] == os.path.join(got["cache"], numbas)
    assert got["note"] == got["period"]  # the compile note follows numba's layout
    assert got["cache"].startswith(str(tmp_path / "xdg"))  # the per-user folder is kept


@pytest.mark.parametrize("inherited", [True, False], ids=["the-packages", "the-users"])
def test_an_inherited_cache_folder_keeps_the_packages_layout(tmp_path, inherited):
    """A process started by one that imported the package (the first run's second process, a
    campaign's workers) inherits its ``NUMBA_CACHE_DIR``: that folder is the package's, and
    its kernels must be filed the same way there, or the parent does not find what the child
    compiled. A folder of the user's own keeps numba's layout."""
    from ffsm_pin._numba_cache import kernel_digest

    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "outside.py").write_text("")
    site = _copy_installed(tmp_path, "site")
    xdg = tmp_path / "xdg"
    folder = xdg / "ffsm-pin" / "numba" / kernel_digest(site / "ffsm_pin")
    given = folder if inherited else tmp_path / "mine"
    code = PLACES.replace("import outside\n", "").replace("outside.f._cache.cache_path", "''")
    code = code.replace("'cache': m.CACHE_DIR", "'cache': os.environ['NUMBA_CACHE_DIR']")
    code = code.replace("import ffsm_pin, ", "import ffsm_pin, os, ")
    proc = _in_copy(site, xdg, code, tmp_path / "elsewhere", numba_cache_dir=given)
    got = json.loads(proc.stdout)
    assert got["cache"] == str(given) and got["first"] == inherited
    if inherited:
        assert got["period"] == os.path.join(given, "control", "period")
    else:
        assert os.path.basename(got["period"]).startswith("control_")


@pytest.mark.parametrize(
    "impl",
    [
        "CacheImpl",  # numba 0.68 (this venv's)
        "_CacheImpl",  # numba before it
        None,  # neither: numba's list unknown
    ],
)
def test_the_locator_registers_only_where_it_knows_numbas_names(impl):
    import types

    from numba.core import caching

    from ffsm_pin._numba_cache import install_locator

    class Impl:
        _locator_classes: list = [object]

    fake = types.SimpleNamespace(_CacheLocator=caching._CacheLocator)
    if impl is not None:
        setattr(fake, impl, Impl)
    got = install_locator(fake)
    if impl is None:
        assert got is None and Impl._locator_classes == [object]
    else:
        assert Impl._locator_classes == [got, object] and got.ffsm_pin_locator
        assert install_locator(fake) is got and len(Impl._locator_classes) == 2  # once
    assert install_locator(types.SimpleNamespace(CacheImpl=Impl)) in (None, got)


def test_two_copies_of_the_package_share_the_compiled_kernels(tmp_path):
    """An installed copy and a checkout (two folders, different modification times, the same
    bytes) load each other's kernels: the second copy compiles nothing."""
    a, b = _copy_installed(tmp_path, "a"), _copy_installed(tmp_path, "b")
    old = time.time() - 86400
    for path in b.rglob("*"):
        os.utime(path, (old, old))
    code = (
        "import json, numpy as np, ffsm_pin\n"
        "from ffsm_pin._array_kernels import mv\n"
        "mv(np.eye(2), np.ones(2))\n"
        "print(json.dumps([ffsm_pin.__file__, len(mv.stats.cache_hits),"
        " len(mv.stats.cache_misses)]))\n"
    )
    xdg = tmp_path / "xdg"
    first = json.loads(_in_copy(a, xdg, code).stdout)
    second = json.loads(_in_copy(b, xdg, code).stdout)
    assert first[0].startswith(str(a)) and second[0].startswith(str(b))
    assert first[1:] == [0, 1]  # compiled in a ...
    assert second[1:] == [1, 0]  # ... loaded in b


SECOND_PATH = (
    "import json, sys\n"
    "import ffsm_pin\n"  # first: the package's numba settings before numba loads
    "from numba.core import event\n"
    "compiled = []\n"
    "class Compiled(event.Listener):\n"
    "    def on_start(self, ev):\n"
    "        d = ev.data or {}\n"
    "        f = d['dispatcher'].py_func if 'dispatcher' in d else None\n"
    "        compiled.append(f.__qualname__ if f else str(d))\n"
    "    def on_end(self, ev):\n"
    "        pass\n"
    "event.register('numba:compile', Compiled())\n"
    "from ffsm_pin.sim.cli import main\n"
    "from ffsm_pin.control._first_compile import finish\n"
    "code = main(sys.argv[2:])\n"
    "finish()\n"
    "with open(sys.argv[1], 'w') as f:\n"
    "    json.dump({'file': ffsm_pin.__file__, 'code': code, 'compiled': compiled}, f)\n"
)


@pytest.mark.slow
def test_a_second_import_path_compiles_nothing(tmp_path):
    """15-90 s (one first compilation). A tiny case-1 run from the repository's root
    (``python -m ffsm_pin.sim`` imports ``./ffsm_pin``), then the same run from another folder
    with the package as pip installs it elsewhere: the second compiles nothing, neither in its
    process (numba's compile events) nor in a second process (no cache file written)."""
    from ffsm_pin.sim.compile_note import MESSAGE

    repo = Path(__file__).resolve().parents[1]
    xdg = tmp_path / "xdg"
    run = ["--case", "case1", "--duration", "0.01", "--no-plots", "--no-html"]
    env = {**os.environ, "XDG_CACHE_HOME": str(xdg)}
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("PYTHONPATH", None)
    cmd = [sys.executable, "-m", "ffsm_pin.sim", *run, "--out", tmp_path / "a"]
    first = subprocess.run(cmd, cwd=repo, env=env, capture_output=True, text=True, timeout=900)
    assert first.returncode == 0, first.stderr
    assert MESSAGE in first.stderr  # an empty cache: compiled, and announced

    def files() -> dict:
        return {p: p.stat().st_mtime_ns for p in xdg.rglob("*") if p.is_file()}

    cached = files()
    assert any(p.match("*/control/period/*.nbi") for p in cached)
    site = _copy_installed(tmp_path, "site")
    report = tmp_path / "second.json"
    second = _in_copy(site, xdg, SECOND_PATH, report, *run, "--out", tmp_path / "b")
    got = json.loads(report.read_text())
    assert got["file"].startswith(str(site)) and got["code"] == 0
    assert got["compiled"] == []
    assert MESSAGE not in second.stderr
    assert files() == cached  # nor did a second process compile anything
    # the first run's second process filed its kernels as the first did (it inherits the
    # package's NUMBA_CACHE_DIR), not in numba's folders per source path, <name>_<sha1>
    assert not [p for p in xdg.rglob("*_*") if p.is_dir() and len(p.name.rsplit("_", 1)[1]) == 40]
