"""The numpydoc entries the spatial model's compiled kernels share (:mod:`ffsm_pin._docstrings`):
the body rotations and joint axes every kernel takes first."""

from __future__ import annotations

from .._docstrings import doc_entries

KERNEL_DOC = doc_entries(
    R="""
        R : ndarray (n+1, 3, 3)
            Body rotations R_k.""",
    R_real="""
        R : ndarray (n+1, 3, 3)
            Body rotations R_k (real).""",
    z="""
        z : ndarray (n, 3)
            Inertial joint axes z_j.""",
    params_R_z=("R", "z"),
    params_R_real_z=("R_real", "z"),
)
