"""The cases of a campaign through the run's set-up before anything runs (:func:`check_cases`)."""

from __future__ import annotations

import warnings

from ..errors import FfsmError
from .campaign import CampaignError
from .cases import Case


def check_cases(cases: list[Case], source: str) -> None:
    """Run :func:`ffsm_pin.sim.setup.prepare` (robot, feasibility, initial errors inside the
    funnels, estimates) on the nominal case and on the first case of every grid point, so a
    value that only the run set-up refuses is bad input before anything runs. Each
    ``[robot]`` section is loaded once (:class:`~ffsm_pin.sim.robots.SharedRobots`), and no
    controller's compiled step is warmed up (:func:`~ffsm_pin.control.compiled.no_warm_up`:
    this process never steps them; the workers load or compile their kernels).

    Parameters
    ----------
    cases : list of Case
        The campaign's cases.
    source : str
        The campaign file, for the messages.
    """
    from ..control.compiled import no_warm_up
    from ..sim.robots import SharedRobots
    from ..sim.run import prepare

    robots = SharedRobots()
    checked: set[int | None] = set()
    for case in cases:
        if case.point_index in checked and not case.nominal:
            continue
        checked.add(case.point_index)
        try:
            with warnings.catch_warnings(), no_warm_up():
                warnings.simplefilter("ignore")
                prepare(case.scenario, robots=robots)
        except FfsmError as exc:
            text = str(exc)
            if text.startswith("controller.params.") and "unknown for controller.type" in text:
                text += (  # another type's keys, set for every case?
                    "; a campaign sets the keys of one controller type's cases in "
                    '[campaign.set_for_controller."<type>"]'
                )
            raise CampaignError(f"{source}: case {case.index} ({case.label()}): {text}") from None
