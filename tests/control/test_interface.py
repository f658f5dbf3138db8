"""The controller interface's signal row (control/interface.py): a SignalLayout places each
signal in one flat row, a SignalRow reads as the mapping of the signals it holds, and a reply
carrying one is taken as ``(u_m, signals)``."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.control.interface import SignalLayout, SignalRow, split_reply

SHAPES = {"a": (3,), "s": (), "b": (2,), "c": ()}


def test_the_layout_places_the_signals_side_by_side_in_order():
    layout = SignalLayout(SHAPES)
    assert layout.size == 7
    assert layout.slots == {"a": (0, 3, (3,)), "s": (3, 4, ()), "b": (4, 6, (2,)), "c": (6, 7, ())}
    assert [layout.index(k) for k in SHAPES] == [slice(0, 3), 3, slice(4, 6), 6]
    assert list(layout.shapes) == list(SHAPES)


def test_a_row_reads_as_its_signals_and_its_views_share_the_row():
    layout = SignalLayout(SHAPES)
    row = np.arange(7.0)
    signals = SignalRow(row, layout)
    assert list(signals) == list(SHAPES) and len(signals) == 4
    assert dict(signals.items()).keys() == SHAPES.keys()
    np.testing.assert_array_equal(signals["a"], [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(signals["b"], [4.0, 5.0])
    assert signals["s"] == 3.0 and np.shape(signals["s"]) == ()
    assert all(np.shape(signals[k]) == shape for k, shape in SHAPES.items())
    assert np.shares_memory(signals["b"], row)  # views: no copy per read
    with pytest.raises(KeyError):
        signals["nope"]


def test_a_reply_with_a_signal_row_is_split_like_one_with_a_dict():
    row = SignalRow(np.zeros(7), SignalLayout(SHAPES))
    u = np.ones(2)
    reply = split_reply((u, row))
    assert reply.u_m is u and reply.signals is row
    assert split_reply(u).signals == {}
