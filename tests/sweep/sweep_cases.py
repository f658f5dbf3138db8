"""Campaign texts shared by the campaign tests: ``SMALL`` is a small campaign of 4 s cases
(dt = 2 ms) on the paper's case 1 with perturbed estimates (1 nominal + 2 spreads x 2 seeds)."""

SMALL = """\
[campaign]
name = "small"
scenario = "case1"
seed = 11
repeat = 2
duration = 4.0
dt = 0.002

[campaign.set]
"controller.estimates.initial" = "perturbed"

[[vary]]
key = "controller.estimates.spread"
values = [0.1, 0.3]
"""
