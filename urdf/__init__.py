"""Robot descriptions shipped with ffsm-pin (installed as ``ffsm_pin.urdf``).

Each ``*.urdf`` is generated from the ``*.toml`` table of the same name by
``python -m ffsm_pin.robot.writer``.
"""
