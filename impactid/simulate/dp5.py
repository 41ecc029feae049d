"""The one Dormand–Prince 5(4) core of impactid's compiled hybrid integrators.

Every rig's kernel (``impactid/rigs/<rig>/kernel.py``) builds its event-driven integrator from the
pieces here, written once and specialised per rig by numba: a rig passes its own ``begin`` and
``stage`` functions (and event functions) as arguments, and numba compiles a version of the core
for them, with the rig's functions inlined. What stays in a rig's kernel is its physics: the
right-hand side of each mode, what happens at a switch (a contact opens, an impact resets a rate,
a valve seats), and what it records.

Method
------
* The tableau of SciPy's ``RK45`` (Dormand & Prince 1980), taken from SciPy so that it is not
  retyped; local extrapolation (the 5th-order solution is propagated), first-same-as-last (the
  last stage is the derivative at the step's end); the embedded 4th-order error estimate; the
  4th-order continuous extension for dense output.
* Error norm: the RMS over the state components of ``err_i / (atol_i + rtol max(|y_i|, |y1_i|))``,
  as in SciPy; a step is accepted when the norm is at most 1.
* Step-size controller (:func:`step_factor`): ``0.9 err^(-1/5)`` within the factor limits 0.2 and 10,
  no growth right after a rejection. The same controller on the squared norm
  (:func:`error_norm_squared`, :func:`accepted_squared`, :func:`step_factor_squared`,
  :func:`shrink_factor_squared`) leaves out the square root, whose latency is on every step's
  critical path: it accepts a step exactly when the square root of its squared norm is at most 1,
  the squared norm equals :func:`error_norm`'s square to a few ulp (the scales' reciprocals
  multiply), and its factors equal ``step_factor``'s to about an ulp (``err2^(-1/10)`` instead of
  ``sqrt(err2)^(-1/5)``).
* Starting step (:func:`initial_step`): Hairer, Nørsett & Wanner's algorithm, as SciPy's
  ``select_initial_step``.
* Event location (:func:`brent`): Brent's method on any scalar function of the step fraction
  (a switching function on the dense output, say), to about 1e-16 of a step.

The functions that take a rig's functions as arguments (:func:`step`, :func:`initial_step`,
:func:`brent`) are inlined into the rig's kernel (``inline="always"``): this keeps the kernels
cachable (a compiled function passed to a separately compiled one is lowered as a dynamic address,
which numba cannot write to its cache).

The rig's ``begin`` and ``stage`` are *not* inlined by numba: a rig compiles them with
``forceinline=True`` (LLVM's ``alwaysinline``) and the flags of the function that calls
:func:`step` (its error model and fast-math flags), so that each is typed and lowered once and LLVM
inlines the compiled body at every stage. numba's own inlining (``inline="always"``) re-types the
whole stage at each of its seven call sites, in a function that grows with each: that cost rig P's
step 25 s of compilation against 3 s now, for the same machine code. The stage number ``s`` reaches
``stage`` as a run-time ``int64`` (:data:`STAGE`), not as a literal, so that ``stage`` has one
compiled signature instead of one per stage (LLVM still folds the constant once it has inlined it).

State layouts
-------------
The state ``y`` is either a **pair** (a 2-tuple of floats ``(q, v)``: one degree of freedom, the
angle and the rate of a follower) or a **vector** (a 1-D float array: several degrees of freedom).
The few operations that depend on the layout (:func:`combine`, :func:`tableau_combine`,
:func:`advance`, :func:`error_norm`, :func:`dense`) have one implementation per layout (numba
overloads chosen by the type of ``y``); the algorithm itself is written once. A pair stays in
registers, which keeps the one-degree-of-freedom rigs as fast as a hand-written scalar integrator.

The rig's functions
-------------------
``begin(mode, t, y, p, law) -> cache``
    called once per step, before its stages: whatever the stages can reuse (the sines and cosines
    of the angles at the step start, say), as a tuple.
``stage(mode, cache, t, y, d, ch, p, law, K, s, monitor)``
    the derivative at time ``t + ch`` and state ``y + d`` (``d`` in the layout of ``y``), written
    into row ``s`` of the stage array ``K`` (``K[s, :]``: for a pair, ``K[s, 0]`` the rate and
    ``K[s, 1]`` the acceleration). The last stage (``s = 6``) is the derivative at the step's
    end; a rig may also write there, into ``monitor``, the quantities it watches for events
    (a gap, a force), computed from the same evaluation.

Compiling a rig's step
----------------------
The stages are inlined (by LLVM) into the rig's function that calls :func:`step` (or
:func:`initial_step`), and numba reference-counts every array a function receives, at every call. When the
increments and decrements cannot be paired up and removed, each stage pays a few atomic
operations: about a third of the time of a cheap (free-flight) step. Two things keep them out:

* pass the rig's parameters (``p``, ``law``) as tuples of floats rather than arrays where they
  are few (they stay in registers, and tuples of floats are not reference-counted);
* compile that function with ``error_model="numpy"``: under numba's default (Python's) error
  model every float division in the stages carries a branch that raises ``ZeroDivisionError``,
  and those branches are what keep the reference counting of the arrays that remain (``K``, the
  monitor) from being removed. Under numpy's error model a division by zero gives an infinity or
  a NaN, i.e. a non-finite trial step, which the rig's loop treats like any other.

Status codes
------------
One set for every kernel (:data:`STATUS_MESSAGES`); kernels return them instead of raising (numba
cannot raise rich errors from parallel loops) and the Python layer turns them into
:class:`~impactid.errors.SimulationError`.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from numba import njit, types
from numba.core.errors import NumbaIRAssumptionWarning
from numba.extending import overload
from scipy.integrate._ivp.rk import RK45 as _RK45

from impactid import compilation

__all__ = ["BAD_INPUT", "EVENTS_FULL", "LAW_RANGE", "MAX_STEPS", "NONFINITE", "OK", "SAMPLES_FULL",
           "STAGE", "STATUS_MESSAGES", "STEP_UNDERFLOW", "accepted_squared", "advance", "brent", "combine", "dense",
           "dense_coefficients", "error_norm", "error_norm_squared", "initial_step", "shrink_factor",
           "shrink_factor_squared", "step", "step_factor", "step_factor_squared", "tableau_combine"]

# numba's pedantic SSA check warns about variables of inlined overloads; harmless (numba issue 7236)
warnings.filterwarnings("ignore", category=NumbaIRAssumptionWarning)

# one line and a progress indication on stderr while a kernel compiles on first use (every rig's kernel
# module imports this one)
compilation.install()

# ---- the tableau (Dormand–Prince 5(4), from SciPy) -----------------------------------------
C = np.ascontiguousarray(_RK45.C, dtype=np.float64)
A = np.ascontiguousarray(_RK45.A, dtype=np.float64)
B = np.ascontiguousarray(_RK45.B, dtype=np.float64)
E = np.ascontiguousarray(_RK45.E, dtype=np.float64)
P = np.ascontiguousarray(_RK45.P, dtype=np.float64)
ORDER = 5

# ---- status codes (one set for every kernel) ------------------------------------------------
OK, MAX_STEPS, STEP_UNDERFLOW, NONFINITE, EVENTS_FULL, SAMPLES_FULL, LAW_RANGE, BAD_INPUT = range(8)
STATUS_MESSAGES = {
    OK: "ok",
    MAX_STEPS: "maximum number of integration steps reached",
    STEP_UNDERFLOW: "step size fell below the floating-point resolution of t",
    NONFINITE: "the state became non-finite",
    EVENTS_FULL: "event table full",
    SAMPLES_FULL: "sample table full",
    LAW_RANGE: "the law left its range (e.g. a restitution law gave xi < 0 beyond 1/gamma)",
    BAD_INPUT: "invalid input to the integrator",
}

_jit = njit(cache=True, inline="always")

#: The stage numbers ``stage`` receives, as run-time ``int64`` values: a global Python integer is a
#: literal to numba, and a literal argument compiles the callee once per value (seven versions of a
#: rig's stage); numpy integers are typed ``int64``, so the stage compiles once.
STAGE = tuple(np.int64(s) for s in range(8))


# ============================================================================================
# Layout primitives: one implementation per state layout (pair of floats, or vector)
# ============================================================================================


def _is_pair(y) -> bool:
    return isinstance(y, types.BaseTuple)


def combine(y, K, coeffs, s, h, work):  # pragma: no cover - replaced by the overload in compiled code
    """``h * sum_{j < s} coeffs[j] K[j]`` in the layout of ``y`` (a tuple, or ``work`` filled)."""


@overload(combine, inline="always")
def _combine(y, K, coeffs, s, h, work):
    if _is_pair(y):
        def pair(y, K, coeffs, s, h, work):
            a = 0.0
            b = 0.0
            for j in range(s):
                a += coeffs[j] * K[j, 0]
                b += coeffs[j] * K[j, 1]
            return (h * a, h * b)
        return pair

    def vector(y, K, coeffs, s, h, work):
        for i in range(y.shape[0]):
            a = 0.0
            for j in range(s):
                a += coeffs[j] * K[j, i]
            work[i] = h * a
        return work
    return vector


def tableau_combine(y, K, s, h, work):  # pragma: no cover - replaced by the overload in compiled code
    """``combine`` with the tableau row of stage ``s`` (a literal integer), its numbers in the code.

    ``s`` = 1..5: the stage increments ``h sum_j A[s, j] K[j]``; 6: the step's increment
    ``h sum_j B[j] K[j]``; 7: the embedded error estimate ``h sum_j E[j] K[j]``.
    """


def _tableau_row(stage: int) -> np.ndarray:
    """The row of the tableau that ``tableau_combine`` uses for ``stage`` (its first ``stage`` entries)."""
    row = A[stage] if stage <= 5 else (B if stage == 6 else E)
    return row[:stage]


def _specialised_combine(stage: int, pair: bool):
    """``tableau_combine`` for one stage, generated from the tableau: its numbers written into the
    code and its zeros left out, as a hand-written kernel has them.

    The sum runs over the stages in the same order as :func:`combine`'s loop, and a left-out term
    ``0 * K[j]`` adds exactly zero to a finite sum, so for finite stages the result is the loop's
    (up to the sign of a zero).
    """
    terms = [(j, float(c)) for j, c in enumerate(_tableau_row(stage)) if c != 0.0]

    def total(component: str) -> str:
        return " + ".join(f"{c!r} * K[{j}, {component}]" for j, c in terms) or "0.0"

    if pair:
        source = (f"def impl(y, K, s, h, work):\n"
                  f"    return (h * ({total('0')}), h * ({total('1')}))\n")
    else:
        source = (f"def impl(y, K, s, h, work):\n"
                  f"    for i in range(y.shape[0]):\n"
                  f"        work[i] = h * ({total('i')})\n"
                  f"    return work\n")
    namespace: dict = {}
    exec(compile(source, f"<dp5.tableau_combine stage {stage}>", "exec"), namespace)  # noqa: S102 - from the tableau
    return namespace["impl"]


@overload(tableau_combine, inline="always", prefer_literal=True)
def _tableau_combine(y, K, s, h, work):
    if isinstance(s, types.IntegerLiteral) and 1 <= s.literal_value <= 7:
        return _specialised_combine(s.literal_value, _is_pair(y))
    return None  # only literal stage numbers: the tableau's rows are not looked up at run time


def advance(y, d, out):  # pragma: no cover - replaced by the overload in compiled code
    """``y + d`` in the layout of ``y`` (a tuple, or ``out`` filled)."""


@overload(advance, inline="always")
def _advance(y, d, out):
    if _is_pair(y):
        def pair(y, d, out):
            return (y[0] + d[0], y[1] + d[1])
        return pair

    def vector(y, d, out):
        for i in range(y.shape[0]):
            out[i] = y[i] + d[i]
        return out
    return vector


def error_norm(y0, y1, err, rtol, atol):  # pragma: no cover - replaced by the overload in compiled code
    """RMS over the components of ``err / (atol + rtol max(|y0|, |y1|))`` (``atol`` in the layout of ``y``)."""


@overload(error_norm, inline="always")
def _error_norm(y0, y1, err, rtol, atol):
    if _is_pair(y0):
        def pair(y0, y1, err, rtol, atol):
            sa = atol[0] + rtol * max(abs(y0[0]), abs(y1[0]))
            sd = atol[1] + rtol * max(abs(y0[1]), abs(y1[1]))
            return math.sqrt(0.5 * ((err[0] / sa) ** 2 + (err[1] / sd) ** 2))
        return pair

    def vector(y0, y1, err, rtol, atol):
        n = y0.shape[0]
        total = 0.0
        for i in range(n):
            scale = atol[i] + rtol * max(abs(y0[i]), abs(y1[i]))
            total += (err[i] / scale) ** 2
        return math.sqrt(total / n)
    return vector


def error_norm_squared(y0, y1, err, rtol, atol):  # pragma: no cover - replaced by the overload in compiled code
    """The square of :func:`error_norm` (the mean over the components of ``(err / scale)^2``), without
    its square root; the scales' reciprocals multiply (they depend on the states only, which are
    known before the error estimate, so the divisions leave the step's critical path)."""


@overload(error_norm_squared, inline="always")
def _error_norm_squared(y0, y1, err, rtol, atol):
    if _is_pair(y0):
        def pair(y0, y1, err, rtol, atol):
            ia = 1.0 / (atol[0] + rtol * max(abs(y0[0]), abs(y1[0])))
            idd = 1.0 / (atol[1] + rtol * max(abs(y0[1]), abs(y1[1])))
            return 0.5 * ((err[0] * ia) ** 2 + (err[1] * idd) ** 2)
        return pair

    def vector(y0, y1, err, rtol, atol):
        n = y0.shape[0]
        total = 0.0
        for i in range(n):
            inv = 1.0 / (atol[i] + rtol * max(abs(y0[i]), abs(y1[i])))
            total += (err[i] * inv) ** 2
        return total / n
    return vector


def dense(x, h, y0, Q, out):  # pragma: no cover - replaced by the overload in compiled code
    """The state at fraction ``x`` of a step of length ``h`` from ``y0`` (continuous extension ``Q``)."""


@overload(dense, inline="always")
def _dense(x, h, y0, Q, out):
    if _is_pair(y0):
        def pair(x, h, y0, Q, out):
            x2 = x * x
            x3 = x2 * x
            x4 = x3 * x
            return (y0[0] + h * (Q[0, 0] * x + Q[0, 1] * x2 + Q[0, 2] * x3 + Q[0, 3] * x4),
                    y0[1] + h * (Q[1, 0] * x + Q[1, 1] * x2 + Q[1, 2] * x3 + Q[1, 3] * x4))
        return pair

    def vector(x, h, y0, Q, out):
        x2 = x * x
        x3 = x2 * x
        x4 = x3 * x
        for i in range(y0.shape[0]):
            out[i] = y0[i] + h * (Q[i, 0] * x + Q[i, 1] * x2 + Q[i, 2] * x3 + Q[i, 3] * x4)
        return out
    return vector


# ============================================================================================
# The step, its control, dense output and event location (layout-independent)
# ============================================================================================


@_jit
def step(stage, begin, mode, t, y, h, p, law, K, work, ynew, monitor):
    """One Dormand–Prince step from ``(t, y)`` of length ``h``.

    ``K[0]`` must hold the derivative at ``(t, y)`` (first-same-as-last: it is ``K[6]`` of the
    previous accepted step). Fills ``K[1..6]`` (``K[6]``: the derivative at the step's end) and,
    through the rig's last stage, ``monitor``. ``work`` and ``ynew`` are scratch arrays for the
    vector layout (unused for a pair). Returns ``(y1, err)``: the 5th-order state at ``t + h`` and
    the embedded error estimate, in the layout of ``y``.
    """
    cache = begin(mode, t, y, p, law)
    # the stages written out with literal stage numbers, so that ``tableau_combine`` is specialised
    # to each row of the tableau (constants in the code, zeros skipped)
    d = tableau_combine(y, K, 1, h, work)
    stage(mode, cache, t, y, d, C[1] * h, p, law, K, STAGE[1], monitor)
    d = tableau_combine(y, K, 2, h, work)
    stage(mode, cache, t, y, d, C[2] * h, p, law, K, STAGE[2], monitor)
    d = tableau_combine(y, K, 3, h, work)
    stage(mode, cache, t, y, d, C[3] * h, p, law, K, STAGE[3], monitor)
    d = tableau_combine(y, K, 4, h, work)
    stage(mode, cache, t, y, d, C[4] * h, p, law, K, STAGE[4], monitor)
    d = tableau_combine(y, K, 5, h, work)
    stage(mode, cache, t, y, d, C[5] * h, p, law, K, STAGE[5], monitor)
    d = tableau_combine(y, K, 6, h, work)
    y1 = advance(y, d, ynew)
    stage(mode, cache, t, y, d, h, p, law, K, STAGE[6], monitor)
    err = tableau_combine(y, K, 7, h, work)
    return y1, err


@_jit
def step_factor(err, rejected):
    """Factor for the next step size after an accepted step with error norm ``err`` (0.9 err^-1/5,
    at most 10; at most 1 right after a rejection)."""
    factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / ORDER))
    return min(1.0, factor) if rejected else factor


#: The largest squared norm whose square root rounds to at most 1: ``sqrt(x) <= 1`` (correctly
#: rounded) exactly when ``x <= 1 + 2^-52``, so :func:`accepted_squared` is the square-root
#: controller's test ``sqrt(err2) <= 1``, without the square root.
ACCEPT_SQUARED = 1.0 + 2.0**-52


@_jit
def accepted_squared(err2):
    """True if a step with squared error norm ``err2`` is accepted (its norm is at most 1)."""
    return err2 <= ACCEPT_SQUARED


@_jit
def step_factor_squared(err2, rejected):
    """:func:`step_factor` from the squared norm: ``0.9 err2^(-1/10)``, at most 10 (at most 1 right
    after a rejection). Equal to ``step_factor(sqrt(err2), rejected)`` to about an ulp."""
    factor = 10.0 if err2 == 0.0 else min(10.0, 0.9 * err2 ** (-0.5 / ORDER))
    return min(1.0, factor) if rejected else factor


@_jit
def shrink_factor_squared(err2, exponent, floor):
    """:func:`shrink_factor` from the squared norm: ``0.9 err2^(-exponent/2)``, at least ``floor``."""
    return max(floor, 0.9 * err2 ** (-0.5 * exponent))


@_jit
def shrink_factor(err, exponent, floor):
    """Factor for retrying a rejected step: ``0.9 err^-exponent``, at least ``floor``. ``exponent``
    is 1/5 (and ``floor`` 0.2) for smooth solutions; a rig whose first step of a phase has a
    weaker singularity (a contact force growing like ``t^p``) passes ``1/(p + 1)``."""
    return max(floor, 0.9 * err ** (-exponent))


@njit(cache=True)
def dense_coefficients(K, Q):
    """Coefficients ``Q`` (state components x 4) of the continuous extension from the stages ``K``."""
    for c in range(Q.shape[0]):
        for j in range(4):
            s = 0.0
            for i in range(7):
                s += K[i, c] * P[i, j]
            Q[c, j] = s


@_jit
def initial_step(stage, begin, mode, t, y, p, law, K, work, monitor, rtol, atol, h_max):
    """Starting step size (Hairer, Nørsett & Wanner, as SciPy's ``select_initial_step``, order 5).

    ``K[0]`` must hold the derivative at ``(t, y)``; ``K[1]`` and ``monitor`` are overwritten."""
    d0 = error_norm(y, y, y, rtol, atol)  # RMS of y / (atol + rtol |y|)
    f0 = combine(y, K, _ONE, 1, 1.0, work)
    d1 = error_norm(y, y, f0, rtol, atol)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, h_max)
    cache = begin(mode, t, y, p, law)
    stage(mode, cache, t, y, combine(y, K, _ONE, 1, h0, work), h0, p, law, K, STAGE[1], monitor)
    d2 = error_norm(y, y, combine(y, K, _DIFF, 2, 1.0, work), rtol, atol) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / ORDER)
    return min(100.0 * h0, h1, h_max)


_ONE = np.ones(1)
_DIFF = np.array([-1.0, 1.0])


@_jit
def brent(fn, args, xa, xb, fa, fb, xtol, side):
    """Root of ``fn(x, args)`` in ``[xa, xb]`` where ``fa = fn(xa)`` and ``fb = fn(xb)`` differ in sign
    (Brent's method; ``xtol`` absolute). ``fn`` is a compiled function, specialised for by numba.

    ``side`` chooses which end of the final bracket (at most ``2 xtol`` wide) is returned: 0 the
    best estimate, +1 the end where ``fn >= 0``, -1 the end where ``fn <= 0`` (an event placed
    just past a crossing, or the last time a condition still held).

    Inlined into its caller (``inline="always"``): a compiled function passed as an argument to a
    separately compiled function would be lowered as a dynamic address, which numba cannot cache.
    """
    if fa == 0.0:
        return xa
    if fb == 0.0:
        return xb
    xc = xa
    fc = fa
    d = xb - xa
    e = d
    for _ in range(100):
        if (fb > 0.0) == (fc > 0.0):
            xc = xa
            fc = fa
            d = xb - xa
            e = d
        if abs(fc) < abs(fb):
            xa = xb
            xb = xc
            xc = xa
            fa = fb
            fb = fc
            fc = fa
        tol = 2.0 * 2.2e-16 * abs(xb) + 0.5 * xtol
        m = 0.5 * (xc - xb)
        if abs(m) <= tol or fb == 0.0:
            break
        if abs(e) >= tol and abs(fa) > abs(fb):
            s = fb / fa
            if xa == xc:
                pp = 2.0 * m * s
                qq = 1.0 - s
            else:
                qq = fa / fc
                r = fb / fc
                pp = s * (2.0 * m * qq * (qq - r) - (xb - xa) * (r - 1.0))
                qq = (qq - 1.0) * (r - 1.0) * (s - 1.0)
            if pp > 0.0:
                qq = -qq
            else:
                pp = -pp
            if 2.0 * pp < min(3.0 * m * qq - abs(tol * qq), abs(e * qq)):
                e = d
                d = pp / qq
            else:
                d = m
                e = m
        else:
            d = m
            e = m
        xa = xb
        fa = fb
        if abs(d) > tol:
            xb += d
        else:
            xb += tol if m > 0.0 else -tol
        fb = fn(xb, args)
    if side == 0 or fb == 0.0 or (fb > 0.0) == (side > 0):
        return xb
    return xc
