"""Robots of the physical-model tests: their URDFs, random states, Pinocchio's dynamics."""
from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import pinocchio as pin

__all__ = ['SCARA_URDF', 'example_urdf', 'rnea', 'states']

SCARA_URDF = Path(__file__).resolve().parents[1] / 'urdf' / 'scara.urdf'


def example_urdf(suffix: str) -> Path:
    """A URDF of the installed example-robot-data, found through its file record."""
    for file in importlib.metadata.files('example-robot-data') or ():
        if str(file).endswith(suffix):
            return Path(str(file.locate()))
    raise FileNotFoundError(suffix)


def states(rng: np.random.Generator, count: int, n: int,
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q', q'' (count, n): uniform in ±1, normal of 1.5 and 5 (SI)."""
    return (rng.uniform(-1.0, 1.0, (count, n)), rng.normal(0.0, 1.5, (count, n)),
            rng.normal(0.0, 5.0, (count, n)))


def rnea(urdf: Path | str, joints: tuple[str, ...] | None, q: np.ndarray, qd: np.ndarray,
         qdd: np.ndarray) -> np.ndarray:
    """Pinocchio's inverse dynamics of the URDF, other joints locked at neutral."""
    full = pin.buildModelFromUrdf(str(urdf))
    lock = [full.getJointId(name) for name in list(full.names)[1:]
            if joints is not None and name not in joints]
    model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
    data = model.createData()
    return np.array([pin.rnea(model, data, q[k], qd[k], qdd[k]) for k in range(q.shape[0])])
