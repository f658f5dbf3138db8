"""The spatial model's parameter vectors: their sizes and the names of their entries
(docs/spatial.md section 3; :mod:`ffsm_pin.model.spatial` for the equations).

* ``theta_z = col(v_0, V_0, ..., V_n)`` (Eq. 4), 3 + 3(n+1), each V_k in body k's frame;
* ``theta_d = (Jbar_0..Jbar_n as (xx, xy, xz, yy, yz, zz), D_kl for k<l row-major 3x3)``
  (Eq. 12), 6(n+1) + 9 n(n+1)/2;
* ``theta_b = col(A_0, theta_d)`` (Eq. 14), A_0 the angular momentum about the CoM.
"""

from __future__ import annotations

from dataclasses import dataclass

# SYM6: the entries (i, j) of a body's symmetric 3x3 inertia in theta_d's order (xx, xy, xz,
# yy, yz, zz), defined in the lower module and read from here by the model and its kernels
from ._pseudo_inertia import SYM6, PseudoInertiaTable, spatial_table


@dataclass(frozen=True)
class SpatialParameterLayout:
    """Sizes and meaning of the spatial parameter vectors."""

    n_bodies: int  # n + 1

    @property
    def n_pairs(self) -> int:
        """Number of body pairs k < l (the off-diagonal D_kl)."""
        return self.n_bodies * (self.n_bodies - 1) // 2

    @property
    def n_z(self) -> int:
        """n_1, size of theta_z."""
        return 3 + 3 * self.n_bodies

    @property
    def n_d(self) -> int:
        """n_2, size of theta_d."""
        return 6 * self.n_bodies + 9 * self.n_pairs

    @property
    def n_b(self) -> int:
        """n_3, size of theta_b."""
        return 3 + self.n_d

    def pseudo_inertia_table(self) -> PseudoInertiaTable:
        """The map theta_d -> P (:func:`._pseudo_inertia.spatial_table`)."""
        return spatial_table(self.n_bodies)

    def theta_z_names(self) -> list[str]:
        """Names of the theta_z entries, in the vector's order (Eq. 4)."""
        names = ["v0x", "v0y", "v0z"]
        for k in range(self.n_bodies):
            names += [f"V{k}{c}" for c in "xyz"]
        return names

    def theta_d_names(self) -> list[str]:
        """Names of the theta_d entries, in the vector's order (Eq. 12)."""
        nb = self.n_bodies
        names = [f"J{k}{'xyz'[i]}{'xyz'[j]}" for k in range(nb) for i, j in SYM6]
        for k in range(nb):
            for l in range(k + 1, nb):
                names += [f"D{k}_{l}{'xyz'[i]}{'xyz'[j]}" for i in range(3) for j in range(3)]
        return names
