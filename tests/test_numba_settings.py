"""The package's numba settings (ffsm_pin/_numba_cache.py): chosen when the user has not set
them, the user's own values win, and both are in place before numba reads its configuration."""

from __future__ import annotations

import json
import os
import subprocess
import sys

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
