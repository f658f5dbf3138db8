"""The pydantic models of the campaign file: each kind of bad input is one line that starts with
the campaign file and the TOML key path, and the samples keep their distribution's parameters."""

from __future__ import annotations

from pathlib import Path

import pytest
from sweep_cases import SMALL

from ffsm_pin.sweep.campaign import CampaignError, Sample, campaign_from_toml

SAMPLE = '[[sample]]\nkey = "controller.k_z"\n'

# name -> (campaign text, fragments; the first is the key path)
BAD = {
    "unknown section": (SMALL + '[[vari]]\nkey = "a"\nvalues = [1]\n',
                        ("vari: unknown key at the top level", "did you mean 'vary'?")),
    "unknown key in a sample": (
        SMALL + SAMPLE + 'distribution = "normal"\nmean = 1\nsdt = 1\n',
        ("sample[0].sdt: unknown key in [sample[0]]", "did you mean 'std'?", "'mean'")),
    "missing distribution": (SMALL + SAMPLE + "low = 1\nhigh = 2\n",
                             ("sample[0].distribution: missing", "'log-uniform'")),
    "missing parameter": (SMALL + SAMPLE + 'distribution = "normal"\nmean = 1\n',
                          ("sample[0].std: missing",)),
    "log-uniform from 0": (SMALL + SAMPLE + 'distribution = "log-uniform"\nlow = 0\nhigh = 1\n',
                           ("sample[0].low = 0: must be > 0",)),
    "low above high": (SMALL + SAMPLE + 'distribution = "uniform"\nlow = 2\nhigh = 1\n',
                       ("sample[0]: low = 2.0 must be < high = 1.0",)),
    "negative std": (SMALL + SAMPLE + 'distribution = "normal"\nmean = 1\nstd = -1\n',
                     ("sample[0].std = -1: must be > 0",)),
    "key not a string": (SMALL.replace('key = "controller.estimates.spread"', "key = 3"),
                         ("vary[0].key: expected a string", "3 (integer)")),
    "duration not positive": (SMALL.replace("duration = 4.0", "duration = -4.0"),
                              ("campaign.duration = -4.0: must be > 0",)),
    "seed negative": (SMALL.replace("seed = 11", "seed = -1"),
                      ("campaign.seed = -1: must be >= 0",)),
    "missing scenario": (SMALL.replace('scenario = "case1"\n', ""),
                         ("campaign.scenario: missing",)),
    "sim.dt twice": (SMALL + '[[vary]]\nkey = "sim.dt"\nvalues = [0.001]\n',
                     ("sim.dt: given twice (in [[vary]] and as campaign.dt)",)),
    "same value twice": (SMALL.replace("[0.1, 0.3]", "[1, 1.0]"),
                         ("vary[0].values: 1.0 appears twice",)),
}  # fmt: skip


@pytest.mark.parametrize("what", list(BAD))
def test_each_error_is_one_line_with_the_key_path(what):
    text, fragments = BAD[what]
    with pytest.raises(CampaignError) as info:
        campaign_from_toml(text, Path("c.toml"))
    msg = str(info.value)
    assert "\n" not in msg and "pydantic" not in msg.lower() and "http" not in msg, msg
    assert msg.startswith(f"c.toml: {fragments[0]}"), msg
    for f in fragments:
        assert f in msg, (f, msg)


@pytest.mark.parametrize(
    ("lines", "params"),
    [
        ('distribution = "uniform"\nlow = -1\nhigh = 2\n', (-1.0, 2.0)),
        ('distribution = "normal"\nstd = 0.5\nmean = 3\n', (3.0, 0.5)),  # in the order mean, std
        ('distribution = "log-uniform"\nlow = 0.01\nhigh = 0.1\n', (0.01, 0.1)),
    ],
)
def test_samples_keep_their_parameters_in_order(lines, params):
    c = campaign_from_toml(SMALL + SAMPLE + lines, Path("c.toml"))
    dist = lines.split('"')[1]
    assert c.sample == (Sample("controller.k_z", dist, params),)
