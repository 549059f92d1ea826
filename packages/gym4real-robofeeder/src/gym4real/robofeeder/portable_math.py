"""Small-matrix arithmetic and elementary functions whose rounding is the same on every CPU.

numpy hands ``@``, ``np.dot``, ``np.linalg.solve`` / ``inv`` and the norm of a vector to its BLAS/LAPACK
(OpenBLAS), which picks its kernels for the CPU when it loads: an AVX-512 Xeon and an AVX2 EPYC sum the
same products in a different order and round differently. Its ``exp``, ``log``, ``tan``, ``arctan2``,
``arcsin`` and ``arccos`` have AVX-512 variants too. MuJoCo's contacts amplify such last-bit differences to
different pick outcomes (``docs/robofeeder-determinism.md``), so every product, solve and norm of the
simulation path is computed here instead:

* products and norms as elementwise numpy multiplications added one term at a time, left to right (each
  multiplication and addition is a separate, correctly rounded IEEE operation: no BLAS, no fused
  multiply-add, no reordering);
* solves by Gaussian elimination with partial pivoting on Python floats, in a fixed order;
* elementary functions through Python's :mod:`math` (the C library's ``libm``, which MuJoCo uses too).
  Scalars call :mod:`math` directly; :func:`atan2`, :func:`arccos` and :func:`exp` apply it elementwise to
  arrays.

The results are identical on any x86-64 CPU with AVX2 and FMA (Intel since Haswell, AMD since Zen),
whatever kernels OpenBLAS or numpy dispatch there. The matrices are tiny (at most 6 x 6), so the Python
loops cost a fraction of a millisecond.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

_ATAN2 = np.frompyfunc(math.atan2, 2, 1)
_ACOS = np.frompyfunc(math.acos, 1, 1)
_EXP = np.frompyfunc(math.exp, 1, 1)


def dot(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """``a @ b`` for ``b`` a vector (k,) or a matrix (k, m), summed over the k terms left to right.

    Args:
        a: Array (..., k): a vector, a matrix (its rows) or a stack of row vectors.
        b: Vector (k,) or matrix (k, m).

    Returns:
        Array (...) for a vector ``b``, (..., m) for a matrix; the dtype of numpy's promotion (float32 stays
        float32).
    """
    x, y = np.asarray(a), np.asarray(b)
    if y.ndim not in (1, 2) or x.ndim < 1 or x.shape[-1] != y.shape[0]:
        msg = f"dot: shapes {x.shape} and {y.shape} do not chain (expected (..., k) and (k,) or (k, m))"
        raise ValueError(msg)
    columns = np.moveaxis(x, -1, 0)  # columns[k] is x[..., k]
    if y.ndim == 2:
        columns = columns[..., None]
    total = columns[0] * y[0]
    for k in range(1, y.shape[0]):
        total = total + columns[k] * y[k]
    return np.asarray(total)


def norm(v: ArrayLike) -> np.ndarray:
    """Euclidean norm along the last axis: ``sqrt`` of the squares added left to right; shape (..., k) -> (...)."""
    x = np.asarray(v, dtype=float)
    return np.sqrt(dot(x * x, np.ones(x.shape[-1])))


def solve(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Solution of ``a x = b``: Gaussian elimination with partial pivoting (as LAPACK's ``gesv``), fixed order.

    Args:
        a: Square matrix (n, n).
        b: Right-hand side (n,) or (n, m).

    Returns:
        x, shaped as ``b``.

    Raises:
        numpy.linalg.LinAlgError: ``a`` is singular (a zero pivot).
    """
    m, rhs = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = m.shape[0]
    if m.shape != (n, n) or rhs.shape[:1] != (n,) or rhs.ndim > 2:
        msg = f"solve: expected a square matrix (n, n) and a right-hand side (n,) or (n, m), got {m.shape}, {rhs.shape}"
        raise ValueError(msg)
    # Python floats: each operation one IEEE double rounding, in the order written
    rows, x = m.tolist(), rhs.reshape(n, -1).tolist()
    for k in range(n):
        p = max(range(k, n), key=lambda i: abs(rows[i][k]))  # the first largest, as LAPACK's pivot
        if rows[p][k] == 0.0:
            raise np.linalg.LinAlgError(f"solve: singular matrix (no pivot in column {k})")
        rows[k], rows[p], x[k], x[p] = rows[p], rows[k], x[p], x[k]
        pivot, xk = rows[k], x[k]
        for i in range(k + 1, n):
            f = rows[i][k] / pivot[k]
            rows[i] = [rij - f * pkj for rij, pkj in zip(rows[i], pivot, strict=True)]
            x[i] = [xij - f * xkj for xij, xkj in zip(x[i], xk, strict=True)]
    for k in range(n - 1, -1, -1):
        acc = x[k]
        for j in range(k + 1, n):
            c = rows[k][j]
            acc = [aj - c * xjj for aj, xjj in zip(acc, x[j], strict=True)]
        x[k] = [aj / rows[k][k] for aj in acc]
    return np.array(x).reshape(rhs.shape)


def inv(a: ArrayLike) -> np.ndarray:
    """Inverse of the square matrix ``a`` (n, n), by :func:`solve` against the identity."""
    m = np.asarray(a, dtype=float)
    return solve(m, np.eye(m.shape[0]))


def atan2(y: ArrayLike, x: ArrayLike) -> np.ndarray:
    """Elementwise ``math.atan2`` (float64; broadcasting as numpy's ``arctan2``)."""
    return np.asarray(_ATAN2(y, x), dtype=float)


def arccos(x: ArrayLike) -> np.ndarray:
    """Elementwise ``math.acos`` (float64); the input must lie in [-1, 1]."""
    return np.asarray(_ACOS(x), dtype=float)


def exp(x: ArrayLike) -> np.ndarray:
    """Elementwise ``math.exp`` (float64); raises ``OverflowError`` above about 709, where numpy gives inf."""
    return np.asarray(_EXP(x), dtype=float)
