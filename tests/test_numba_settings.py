"""The package's numba settings (ffsm_pin/_numba_cache.py): chosen when the user has not set
them, the user's own values win, and both are in place before numba reads its configuration."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time

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
