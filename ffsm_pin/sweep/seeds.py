"""Random streams of a campaign: one :class:`numpy.random.SeedSequence` per case and purpose.

A case's stream is derived from the campaign's root seed, the *content* of its grid point
(the varied keys and their values, hashed) and its repeat index, never from its position in
the list of cases: adding a value to a ``[[vary]]`` axis, or a new repeat, leaves every
earlier case's stream (hence its scenario and its ``case_hash``) exactly as it was.

Within a case, each purpose gets its own child: ``"estimates"`` (the integer written to
``controller.estimates.seed``), one per sampled key (``"sample:"`` and its dotted path) and one
per dispersed key (``"disperse:"`` and its dotted path): adding a key leaves the others' draws
unchanged.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

import numpy as np

from .._docstrings import doc_entries, fill_doc

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    root_seed="""
        root_seed : int
            The campaign's seed.""",
    point="""
        point : mapping
            The case's grid point.""",
    repeat="""
        repeat : int
            Its repeat index.""",
    params_root_seed_point_repeat=("root_seed", "point", "repeat"),
)

__all__ = ["case_stream", "estimates_seed", "words"]


def words(text: str, n: int = 4) -> tuple[int, ...]:
    """``n`` 32-bit words of SHA-256(text): a stable integer identity for a string.

    Parameters
    ----------
    text : str
        The string.
    n : int
        Number of words.

    Returns
    -------
    tuple of int
        The words.
    """
    digest = hashlib.sha256(text.encode("utf-8")).digest()
    return tuple(int.from_bytes(digest[4 * i : 4 * i + 4], "little") for i in range(n))


def point_key(point: Mapping[str, Any]) -> str:
    """Canonical text of a grid point ``{dotted key: value}`` (order-independent)."""
    return json.dumps(dict(point), sort_keys=True, separators=(",", ":"))


@fill_doc(_DOC)
def case_stream(
    root_seed: int, point: Mapping[str, Any], repeat: int, purpose: str
) -> np.random.SeedSequence:
    """The SeedSequence of one case (grid point, repeat index) for one purpose.

    %(params_root_seed_point_repeat)s
    purpose : str
        What the stream is for (e.g. ``"estimates"``).

    Returns
    -------
    numpy.random.SeedSequence
        The stream.
    """
    spawn_key = (*words(point_key(point)), int(repeat), *words(purpose, 2))
    return np.random.SeedSequence(int(root_seed), spawn_key=spawn_key)


@fill_doc(_DOC)
def estimates_seed(root_seed: int, point: Mapping[str, Any], repeat: int) -> int:
    """A non-negative 63-bit integer for ``controller.estimates.seed`` (fits a TOML integer).

    %(params_root_seed_point_repeat)s

    Returns
    -------
    int
        The seed.
    """
    state = case_stream(root_seed, point, repeat, "estimates").generate_state(1, np.uint64)
    return int(state[0]) >> 1
