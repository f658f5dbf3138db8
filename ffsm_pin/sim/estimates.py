"""Initial parameter estimates of a scenario (``[controller.estimates]``): Table 2, the truth,
a seeded perturbation of it, or explicit vectors."""

from __future__ import annotations

import numpy as np

from .. import paper
from ..errors import ScenarioError
from ..model import ReducedModel
from ..scenario.spec import Scenario


def initial_estimates(scenario: Scenario, model: ReducedModel, truth):
    """(theta_z, theta_d, theta_b)-hat at t = 0 per ``[controller.estimates]`` (docs/cli.md):
    ``truth`` for "true" (and the known-model scheme), Table 2 for "paper" (the paper's robot
    sizes only), :func:`perturbed_estimates` for "perturbed", the given vectors for
    "explicit"; a ScenarioError names what does not fit."""
    est = scenario.controller.estimates
    tz, td, tb = truth
    if scenario.controller.scheme == "known-model" or est.initial == "true":
        return tz.copy(), td.copy(), tb.copy()
    if est.initial == "paper":
        sizes = (model.n_z, model.n_d, model.n_b)
        paper_sizes = (len(paper.THETA_Z_HAT0), len(paper.THETA_D_HAT0), len(paper.THETA_B_HAT0))
        if sizes != paper_sizes:
            raise ScenarioError(
                f"controller.estimates.initial = 'paper' (Table 2) has sizes {paper_sizes} for "
                f"(theta_z, theta_d, theta_b), this robot needs {sizes}; use 'perturbed', "
                "'true' or 'explicit'"
            )
        return (
            np.array(paper.THETA_Z_HAT0, float),
            np.array(paper.THETA_D_HAT0, float),
            np.array(paper.THETA_B_HAT0, float),
        )
    if est.initial == "perturbed":
        return perturbed_estimates(model, truth, est.spread, est.seed)
    out = []
    for name, given, size in (
        ("theta_z", est.theta_z, model.n_z),
        ("theta_d", est.theta_d, model.n_d),
        ("theta_b", est.theta_b, model.n_b),
    ):
        vec = np.asarray(given, dtype=float)
        if vec.shape != (size,):
            raise ScenarioError(
                f"controller.estimates.{name} has {vec.size} entries, this robot needs {size} "
                f"(layout: {_layout_name(model)})"
            )
        out.append(vec)
    return tuple(out)


def _layout_name(model) -> str:
    if model.m3 == 3:
        return "spatial"
    return "collinear" if model.layout.collinear else "general 2-D"


MAX_PERTURBATION_DRAWS = 200


def perturbed_estimates(model: ReducedModel, truth, spread: float, seed: int):
    """Every true parameter times (1 + U(-spread, spread)), from a generator seeded with
    ``seed``. A draw of theta_d whose inertia M(q, theta_d-hat) is not positive definite
    (at 64 seeded random configurations) is redrawn from the same stream: independent
    perturbations of 30 % make M-hat indefinite for 15-50 % of draws, which no filter (46)
    can use."""
    tz, td, tb = truth
    rng = np.random.default_rng(seed)
    m3 = model.m3
    check = np.random.default_rng(seed + 1).uniform(-np.pi, np.pi, (64, model.n_joints + m3))
    if m3 > 1:  # base attitudes as MRPs on the |s| <= 1 branch: |s_i| <= 0.5
        check[:, :m3] *= 0.5 / np.pi

    def perturb(x):
        return x * (1.0 + rng.uniform(-spread, spread, size=np.shape(x)))

    def inertia(x):
        for _ in range(MAX_PERTURBATION_DRAWS):
            cand = perturb(x)
            if all(
                np.linalg.eigvalsh(model.mass_matrix(cand, _q_b(c[:m3]), c[m3:]))[0] > 0
                for c in check
            ):
                return cand
        raise ScenarioError(
            f"controller.estimates: no positive-definite perturbation of theta_d found in "
            f"{MAX_PERTURBATION_DRAWS} draws (spread {spread}, seed {seed}); use a smaller spread"
        )

    tz_hat = perturb(tz)
    td_hat = inertia(td)
    tb_hat = np.concatenate((perturb(tb[:m3]), inertia(td)))
    return tz_hat, td_hat, tb_hat


def _q_b(x):
    """The base attitude argument of a model: a number (planar) or an MRP 3-vector."""
    return x[0] if len(x) == 1 else x
