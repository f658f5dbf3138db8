"""The compiled period's fixed arguments in one reference (a numba ``StructRef``).

Every period the controller hands the compiled period (:func:`.period.period_of`) the same
bundles: the model's constants, the law's and the reference's fields, the state and the
outputs (advanced and written in place). As separate arguments numba types and unboxes each
of their 50-odd arrays and numbers on every call (about 4.6 us a period, more than the planar
geometry step; benchmarks/README.md, "The period's fixed arguments in one box"); held in a
:class:`PeriodBox`, the call unboxes one reference. The box holds the same Python objects
(arrays by reference, not copies): what the period writes into the state and the outputs is
what the controller reads.

The type is defined here, apart from the compiled functions that take it: numba's cache
misses a function defined in the same module as the structref type it takes (numba issue
9030).
"""

from __future__ import annotations

from typing import Any

from numba import njit, types
from numba.experimental import structref


@structref.register
class PeriodBoxType(types.StructRef):
    """numba's type of a :class:`PeriodBox` (one per combination of the fields' types)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class PeriodBox(structref.StructRefProxy):
    """The period's fixed arguments: ``geo`` (the model's kernel constants), ``law`` and
    ``ref`` (the fields of :class:`~.period.PeriodLaw` and of the reference arrays),
    ``state`` and ``out`` (the fields of :class:`~.period.PeriodState` and
    :class:`~.period.PeriodOutputs`). Made by :func:`period_box`."""


_FIELDS = ("geo", "law", "ref", "state", "out")
structref.define_proxy(PeriodBox, PeriodBoxType, list(_FIELDS))


@njit(cache=True)
def _new_box(geo, law, ref, state, out):
    return PeriodBox(geo, law, ref, state, out)


def period_box(geo: Any, law: tuple, ref: tuple, state: tuple, out: tuple) -> PeriodBox:
    """The period's fixed arguments in one box (the same objects, not copies).

    Parameters
    ----------
    geo : NamedTuple
        The model's kernel constants.
    law, ref, state, out : tuple
        The fields of the law, the reference arrays, the state and the outputs.

    Returns
    -------
    PeriodBox
        The box :func:`.period.period_of` takes first.
    """
    return _new_box(geo, law, ref, state, out)


__all__ = ["PeriodBox", "PeriodBoxType", "period_box"]
