"""Joint friction with a Stribeck (stick-slip) characteristic: viscous, Coulomb and static.

Per joint i, as a function of the joint velocity v (rad/s or m/s):

    F_i(v) = (Fc_i + (Fs_i − Fc_i) exp(−(v / vs_i)²)) tanh(v / eps_i) + Fv_i v

- ``viscous`` Fv (N·m·s/rad or N·s/m): the term proportional to speed;
- ``coulomb`` Fc (N·m or N): the sliding friction level at speeds well above vs;
- ``static`` Fs >= Fc (N·m or N): the breakaway level, reached at speeds of a few eps;
- ``stribeck_velocity`` vs (rad/s or m/s): how fast friction drops from Fs to Fc once the
  joint slides: the falling part of the curve (negative damping) is what makes a joint
  under slow tracking stick, break away and slip again (stick-slip);
- ``stick_velocity`` eps (rad/s or m/s): the velocity band of sticking. Below it the
  friction is a steep viscous law of slope about Fs / eps that holds the joint almost
  still against any effort up to Fs, the regularised form of static friction.

The friction is a function of the velocity alone, so a recorded effort is exactly
τ = ID(q, q', q'') + F(q'): the relation an identifier learns. Keeping the model continuous
(no switching between a stuck and a sliding state) also keeps fixed-step RK4 exact to its
order; the price is that a stuck joint creeps at a speed of about eps · (effort / Fs).
:meth:`JointFriction.max_stable_step` bounds the integration step that the steep band
allows for a given inertia.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from scara_ident_ros.dynamics.params import ParamError, _vector

__all__ = ['JointFriction', 'RK4_STABILITY']

#: Largest h·λ for which classical RK4 is stable on a real decaying mode exp(−λ t) is about
#: 2.78; the step bound keeps a margin below it.
RK4_STABILITY = 2.5


@dataclass(frozen=True)
class JointFriction:
    """Friction of n joints (module docstring); every field has one value per joint.

    Attributes
    ----------
    viscous : tuple of n float
        Fv, >= 0 (N·m·s/rad or N·s/m).
    coulomb : tuple of n float
        Fc, >= 0 (N·m or N).
    static : tuple of n float
        Fs, >= Fc (N·m or N).
    stribeck_velocity : tuple of n float
        vs, > 0 (rad/s or m/s).
    stick_velocity : tuple of n float
        eps, > 0 (rad/s or m/s).

    Raises
    ------
    ParamError
        For values of the wrong count or sign, or a static level below the Coulomb level.
    """

    viscous: tuple[float, ...]
    coulomb: tuple[float, ...]
    static: tuple[float, ...]
    stribeck_velocity: tuple[float, ...]
    stick_velocity: tuple[float, ...]
    _fv: np.ndarray = field(init=False, repr=False, compare=False)
    _fc: np.ndarray = field(init=False, repr=False, compare=False)
    _dfs: np.ndarray = field(init=False, repr=False, compare=False)
    _minus_inv_vs2: np.ndarray = field(init=False, repr=False, compare=False)
    _inv_eps: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        n = len(self.viscous)
        set_ = object.__setattr__
        for name in ('viscous', 'coulomb', 'static'):
            set_(self, name, _vector(name, getattr(self, name), n, minimum=0.0, strict=False))
        for name in ('stribeck_velocity', 'stick_velocity'):
            set_(self, name, _vector(name, getattr(self, name), n, minimum=0.0))
        for i, (fc, fs) in enumerate(zip(self.coulomb, self.static)):
            if fs < fc:
                raise ParamError(f'static[{i}] = {fs!r} must be >= coulomb[{i}] = {fc!r} '
                                 '(friction at breakaway is at least the sliding friction)')
        set_(self, '_fv', np.array(self.viscous))
        set_(self, '_fc', np.array(self.coulomb))
        set_(self, '_dfs', np.array(self.static) - np.array(self.coulomb))
        set_(self, '_minus_inv_vs2', -1.0 / np.square(self.stribeck_velocity))   # s²/rad²
        set_(self, '_inv_eps', 1.0 / np.array(self.stick_velocity))              # s/rad

    @classmethod
    def scaled(cls, effort_max: Sequence[float] | np.ndarray, *, viscous: float, coulomb: float,
               static: float, stribeck_velocity: float, stick_velocity: float
               ) -> JointFriction:
        """Friction in proportion to each joint's effort limit: a plausible default.

        Parameters
        ----------
        effort_max : sequence of n float or ndarray of shape (n,)
            Effort limits (N·m or N).
        viscous : float
            Fv as a fraction of effort_max per unit speed (s/rad or s/m).
        coulomb, static : float
            Fc and Fs as fractions of effort_max.
        stribeck_velocity, stick_velocity : float
            vs and eps, the same for every joint (rad/s or m/s).
        """
        limit = np.asarray(effort_max, dtype=float)
        n = limit.size
        return cls(tuple((viscous * limit).tolist()), tuple((coulomb * limit).tolist()),
                   tuple((static * limit).tolist()), (stribeck_velocity,) * n,
                   (stick_velocity,) * n)

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return len(self.viscous)

    def __call__(self, qd: np.ndarray) -> np.ndarray:
        """Friction efforts F(q') (N·m or N) for velocities ``qd`` (n,) or (N, n) (rad/s or
        m/s), in the shape of ``qd`` and of the sign of the velocity."""
        level = self._fc + self._dfs * np.exp(qd * qd * self._minus_inv_vs2)   # N·m, N
        return level * np.tanh(qd * self._inv_eps) + self._fv * qd

    def slope_max(self) -> np.ndarray:
        """Steepest slope dF/dv of each joint, at v = 0: Fs / eps + Fv, shape (n,).

        In N·m·s/rad or N·s/m.
        """
        return np.array(self.static) * self._inv_eps + self._fv

    def max_stable_step(self, inertia: Sequence[float]) -> float:
        """Longest RK4 step (s) for which the sticking band stays stable.

        A joint of inertia I in its sticking band is a decaying mode of rate slope / I;
        RK4 needs h · rate <= :data:`RK4_STABILITY`.

        ``inertia`` (n,) is a lower bound of the inertia each joint sees (kg·m² or kg), e.g.
        its rotor inertia; ``inf`` when no joint has friction.
        """
        rate = self.slope_max() / np.maximum(np.asarray(inertia, dtype=float), 1e-300)  # 1/s
        fastest = float(rate.max()) if rate.size else 0.0
        return RK4_STABILITY / fastest if fastest > 0.0 else float('inf')
