"""Cheap readings of a control request's arrays, for :class:`~nodnav.control.mpc.BSplineMPC`: a
step takes them for every robot, so the usual case (arrays already as wanted, a robot exactly where
the last step said) is decided without NumPy's general machinery."""

from __future__ import annotations

import numpy as np

FLOAT64 = np.dtype(np.float64)
"""The float64 dtype, the one NumPy gives a float array it makes."""


def apart(a: np.ndarray, b: np.ndarray) -> bool:
    """``np.hypot(*(a - b)) > 1e-6`` for two points ``(2,)``, deciding without the hypot where
    the coordinates' differences alone do, with room to spare for rounding (``max(|dx|, |dy|)
    <= hypot <= |dx| + |dy|``): as a rule the robot is exactly where the last step said (both
    differences zero)."""
    dx, dy = abs(float(a[0]) - float(b[0])), abs(float(a[1]) - float(b[1]))
    if dx > 2e-6 or dy > 2e-6:
        return True
    if dx + dy <= 0.5e-6:
        return False
    return bool(np.hypot(a[0] - b[0], a[1] - b[1]) > 1e-6)


def floats(x, shape: tuple[int]) -> np.ndarray:
    """``np.asarray(x, dtype=float).reshape(shape)``, ``x`` itself where it is already that (a
    method's arrays, as a rule: the conversion's cost is most of a request's validation)."""
    # ``is`` the float64 dtype: a third of ``==``'s cost; an equal dtype not this object takes the general path.
    if type(x) is np.ndarray and x.dtype is FLOAT64 and x.ndim == 1 and (shape[0] < 0 or x.shape == shape):
        return x
    return np.asarray(x, dtype=float).reshape(shape)
