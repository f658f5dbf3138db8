"""The numpydoc entries the control layer's docstrings share (:mod:`ffsm_pin._docstrings`): the
compiled period's arguments (``control/fast.py``, ``control/fast_spatial.py``, the baselines'
kernels) and the state a resolved rate is taken at. A docstring names them ``%(name)s``."""

from __future__ import annotations

from .._docstrings import doc_entries

CONTROL_DOC = doc_entries(
    # the bookkeeping of a period a lock-step runner ran (control/lockstep.py)
    params_settle="""
        Parameters
        ----------
        meas : Measurement
            The period's measurement.
        status, idx, value : int, int, float
            What the period returned.""",
    # one period of the paper's law (control/controller.py, control/compiled_period.py)
    params_step_period="""
        Parameters
        ----------
        meas : Measurement
            The measurement at the period's start t [s].
        dt : float
            The period [s].""",
    sections_step_period="""
        %(params_step_period)s

        Returns
        -------
        ControlOutput
            The period's outputs (copies, on the compiled backend).""",
    geo="""
        geo : PlanarKernelConstants or SpatialKernelConstants
            The model's kernel constants.""",
    law="""
        law : PeriodLaw
            The run's constants.""",
    dt="""
        dt : float
            The period [s].""",
    meas="""
        meas : Measurement
            The measurement at t.""",
    # a (possibly complex) state at which a joint-rate command is taken
    t_q_z="""
        t : float or complex
            Time [s].
        q_b : float, complex or ndarray
            Base attitude [rad] or MRP.
        q_m : ndarray, shape (n,)
            Joint angles [rad].
        z_e : ndarray
            End-effector pose.""",
    gain_dt="""
        gamma_1 : float
            Adaptation gain.
        dt : float
            Step [s].""",
    theta_d_true="""
        theta_d : ndarray
            The true dynamic parameters.""",
    rows="""
        q_b, q_m, w, dw_b : ndarray
            The recorded rows (shapes above).""",
    # the steps of the compiled period (control/period.py)
    params_kinematic_law="""
        Parameters
        ----------
        %(geo)s
        %(law)s
        ref : ReferenceArrays
            The task reference.
        ns : NullSpaceTerm or None
            ``law.null_space``.
        %(t_q_z)s
        theta_b, theta_z : ndarray
            Estimates of Eqs. (28) and (42).
        w_b : ndarray, shape (m3,)
            Base angular velocity [rad/s].""",
    params_geometry_terms="""
        Parameters
        ----------
        %(geo)s
        %(law)s
        %(dt)s
        %(meas)s
        state : PeriodState
            The estimates at t.""",
    params_dynamic_level="""
        Parameters
        ----------
        %(geo)s
        terms : tuple
            Those of :func:`geometry_terms`.
        %(law)s
        %(dt)s
        %(meas)s
        w_mc, w_mc_dot : ndarray, shape (n,)
            Commanded joint rates [rad/s] and their derivative [rad/s^2].
        sens : ndarray
            d w_mc / d w_b (zero except for Eq. 81).
        state : PeriodState
            Advanced in place.""",
    sections_reaction_rows_of="""
        Parameters
        ----------
        %(rows)s

        Returns
        -------
        tuple
            The four arrays, contiguous.""",
    # a baseline's compiled period (control/gjm_ct_kernels.py, control/adaptive_ct_kernels.py)
    params_baseline_period="""
        Parameters
        ----------
        %(geo)s
        gains_f : tuple
            The fields of the baseline's kernel gains (``GjmKernelGains``,
            ``AdaptiveCtKernelGains``).
        ref_f : tuple
            The fields of a ``ReferenceArrays``.
        meas_f : tuple
            The fields of a ``Measurement``.
        est_f : tuple
            The fields of the ``Estimates``.""",
    params_resolved_rates="""
        Parameters
        ----------
        %(geo)s
        gains : NamedTuple
            Its ``n_task``, ``k_z`` and ``threshold`` are read.
        ref : ReferenceArrays
            The task reference.
        %(t_q_z)s
        theta_z, theta_b : ndarray
            The estimates.""",
    # the baselines' default gains (control/resolved_motion.py)
    funnel_task_drift="""
        dt : float
            The control period [s].
        m2 : int
            Position coordinates.
        n_task : int
            Task components.
        drift : float
            Drift speed the model may miss [m/s] (:func:`~.resolved_motion.drift_bound`).""",
    params_funnel="""
        Parameters
        ----------
        funnel : FunnelParams
            The scenario's end-effector funnel.
        %(funnel_task_drift)s""",
    # a robot holding a body in its hand (control/held_body.py)
    params_robot_held="""
        Parameters
        ----------
        robot : Robot
            The robot.
        held : pin.Inertia
            The held body in the end-effector frame.""",
)
