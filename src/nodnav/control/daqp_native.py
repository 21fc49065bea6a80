"""DAQP's C solver ``daqp_quadprog`` called directly, from compiled code, instead of through ``daqp.solve``.

``daqp.solve`` (the Cython wrapper of the ``daqp`` wheel) fills three C structs, calls
``daqp_quadprog`` (which sets up a workspace, solves and frees it) and packs the result into a
tuple and a dict: 3-6 us of Python per call around the solver's own work. The same C function is
exported by the wheel's extension module, so a compiled kernel (:func:`quadprog_kernel`) can fill
the same structs and call it at its address: the same solver on the same data with the same
settings, hence the same bits, and a control step compiled as a whole could include it.

The structs' layouts are not part of any stable ABI: they are those of DAQP 0.11.0, read from
its release's headers (``csrc/include/types.h`` and ``api.h`` of the 0.11.0 sdist) and checked
against the debug information of the wheel's extension (gdb's ``ptype /o``). Any other
installed version is refused (:func:`quadprog_address` returns None, logged once) and the
callers use ``daqp.solve``, so a new release is never read with the wrong layout.

The kernel takes the function's address as an argument and calls it through
:func:`_call_quadprog` (an LLVM cast and call), so nothing process-specific is compiled into it
and it is cached on disk like the package's other kernels (a ctypes function object would be
compiled in as a constant address, which numba refuses to cache).
"""

from __future__ import annotations

import ctypes
import functools
import importlib.metadata
import logging
import sys

import daqp
import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from nodnav.compiled import compiled

#: The DAQP release whose struct layouts this module writes (see the module docstring).
VERIFIED_VERSION = "0.11.0"

#: ``daqp.solve``'s defaults (DAQP 0.11.0's ``constants.h``): the primal tolerance and the proximal
#: weight (negative: regularise only if the Hessian needs it).
DEFAULT_PRIMAL_TOL = 1e-6
DEFAULT_EPS_PROX = -1e-6
DAQP_INF = 1e30

_log = logging.getLogger(__name__)


class Settings(ctypes.Structure):
    """DAQP 0.11.0's ``DAQPSettings`` (136 bytes)."""

    _fields_ = [("primal_tol", ctypes.c_double), ("dual_tol", ctypes.c_double), ("zero_tol", ctypes.c_double),
                ("pivot_tol", ctypes.c_double), ("progress_tol", ctypes.c_double),
                ("cycle_tol", ctypes.c_int), ("iter_limit", ctypes.c_int),
                ("fval_bound", ctypes.c_double), ("eps_prox", ctypes.c_double), ("eta_prox", ctypes.c_double),
                ("rho_soft", ctypes.c_double), ("rel_subopt", ctypes.c_double), ("abs_subopt", ctypes.c_double),
                ("sing_tol", ctypes.c_double), ("refactor_tol", ctypes.c_double), ("time_limit", ctypes.c_double),
                ("w_soft", ctypes.c_double), ("eq_reduction", ctypes.c_int), ("presolve", ctypes.c_int)]


#: Bytes of DAQP 0.11.0's ``DAQPProblem`` and ``DAQPResult`` (the kernel writes them as 64-bit words).
PROBLEM_WORDS = 10
RESULT_WORDS = 8


def settings_block(primal_tol: float = DEFAULT_PRIMAL_TOL, eps_prox: float = DEFAULT_EPS_PROX) -> np.ndarray:
    """The ``DAQPSettings`` bytes ``daqp.solve`` passes for these two keywords, every other
    setting at its default (the keyword defaults of DAQP 0.11.0's ``daqp.pyx``)."""
    s = Settings(primal_tol=primal_tol, dual_tol=1e-12, zero_tol=1e-11, pivot_tol=1e-8, progress_tol=1e-14,
                 cycle_tol=10, iter_limit=10000, fval_bound=DAQP_INF, eps_prox=eps_prox, eta_prox=-1.0,
                 rho_soft=1e-6, rel_subopt=0.0, abs_subopt=0.0, sing_tol=3.7e-11, refactor_tol=1e-9,
                 time_limit=0.0, w_soft=0.0, eq_reduction=0, presolve=1)
    block = np.frombuffer(bytes(s), dtype=np.uint8).copy()
    block.flags.writeable = False
    return block


def layout_verified(version: str) -> bool:
    """Whether ``version`` of DAQP is the one whose struct layouts this module writes."""
    return version == VERIFIED_VERSION


@functools.cache
def quadprog_address() -> int | None:
    """The address of the installed ``daqp`` extension's ``daqp_quadprog``, or None (logged
    once) if its version's layouts are not verified, the platform is not 64-bit little-endian,
    numba's JIT is disabled or the symbol cannot be loaded (a build that does not export it)."""
    try:
        version = importlib.metadata.version("daqp")
    except importlib.metadata.PackageNotFoundError:
        version = "unknown"
    if not layout_verified(version):
        _log.warning("DAQP %s is not %s, whose struct layouts daqp_native verified: using daqp.solve",
                     version, VERIFIED_VERSION)
        return None
    if ctypes.sizeof(ctypes.c_void_p) != 8 or sys.byteorder != "little":  # the kernel writes 64-bit little-endian words
        _log.warning("daqp_native writes DAQP's structs as 64-bit little-endian words: using daqp.solve")
        return None
    if getattr(numba.config, "DISABLE_JIT", False):  # the kernel's call is LLVM code, which plain Python cannot run
        _log.warning("numba's JIT is disabled: using daqp.solve")
        return None
    try:
        function = ctypes.CDLL(daqp.__file__).daqp_quadprog
    except (OSError, AttributeError) as error:
        _log.warning("daqp_quadprog not loadable from %s (%s): using daqp.solve", daqp.__file__, error)
        return None
    return ctypes.cast(function, ctypes.c_void_p).value


@intrinsic
def _call_quadprog(typingctx, address, result, problem, settings):
    """``((void (*)(void *, void *, void *)) address)(result, problem, settings)``: the call of
    ``daqp_quadprog(DAQPResult *, DAQPProblem *, DAQPSettings *)`` at a run-time address."""
    sig = types.void(address, result, problem, settings)

    def codegen(context, builder, signature, args):
        pointer = ir.IntType(8).as_pointer()
        function_type = ir.FunctionType(ir.VoidType(), [pointer, pointer, pointer])
        function = builder.inttoptr(args[0], function_type.as_pointer())
        builder.call(function, [builder.inttoptr(a, pointer) for a in args[1:]])
        return context.get_dummy_value()

    return sig, codegen


@compiled
def quadprog_kernel(address, h, f, a, bupper, blower, sense, settings):
    """``daqp_quadprog`` at ``address`` on the QP ``h, f, a, bupper, blower, sense`` (C-contiguous
    float64, ``sense`` int32; the first ``len(bupper) - len(a)`` constraints simple bounds), with
    the ``settings`` bytes (:func:`settings_block`): the structs ``daqp.solve`` fills, filled the
    same way. Returns ``x, lam, fval, exitflag, iterations, nodes, solve_time, setup_time`` (``x``
    and ``lam`` unwritten where the set-up fails, as ``daqp.solve``'s)."""
    n = a.shape[1]
    m = bupper.shape[0]
    rows = a.shape[0]
    x = np.empty(n)
    lam = np.empty(m)
    problem = np.zeros(10, dtype=np.int64)  # DAQPProblem: int n, m, ms; 7 pointers; int nh, problem_type
    problem[0] = n | (m << 32)
    problem[1] = m - rows
    problem[2] = h.ctypes.data
    problem[3] = f.ctypes.data
    if rows > 0:
        problem[4] = a.ctypes.data
    if m > 0:
        problem[5] = bupper.ctypes.data
        problem[6] = blower.ctypes.data
        problem[7] = sense.ctypes.data
    # problem[8], [9]: no break points (NULL, nh = 0), problem_type 0 (a QP)
    result = np.zeros(8, dtype=np.int64)  # DAQPResult: x, lam, fval, soft_slack, int exitflag, iter, nodes; 2 times
    result[0] = x.ctypes.data
    if m > 0:
        result[1] = lam.ctypes.data
    _call_quadprog(address, result.ctypes.data, problem.ctypes.data, settings.ctypes.data)
    reals = result.view(np.float64)
    exitflag = np.int32(result[4] & 0xFFFFFFFF)
    iterations = np.int32(result[4] >> 32)
    nodes = np.int32(result[5] & 0xFFFFFFFF)
    return x, lam, reals[2], exitflag, iterations, nodes, reals[6], reals[7]


@functools.cache
def settings_for(primal_tol: float | None, eps_prox: float | None) -> np.ndarray:
    """:func:`settings_block`, one per pair of values (None: the default; read-only, remembered)."""
    return settings_block(DEFAULT_PRIMAL_TOL if primal_tol is None else primal_tol,
                          DEFAULT_EPS_PROX if eps_prox is None else eps_prox)


def quadprog(H: np.ndarray, f: np.ndarray, A: np.ndarray, bupper: np.ndarray, blower: np.ndarray | None = None,
             sense: np.ndarray | None = None, primal_tol: float = DEFAULT_PRIMAL_TOL,
             eps_prox: float = DEFAULT_EPS_PROX, address: int | None = None) -> tuple:
    """``daqp.solve(H, f, A, bupper, blower, sense, primal_tol=..., eps_prox=...)``'s
    ``(x, fval, exitflag, info)`` (``info``: ``iterations``, ``nodes``, ``lam``, ``solve_time``,
    ``setup_time``), computed by :func:`quadprog_kernel`; by ``daqp.solve`` itself where the
    installed DAQP is refused (:func:`quadprog_address`). ``address`` overrides the loaded one
    (tests)."""
    if address is None:
        address = quadprog_address()
    if address is None:
        return daqp.solve(H, f, A, bupper, blower, sense, primal_tol=primal_tol, eps_prox=eps_prox)
    m = len(bupper)
    if blower is None:
        blower = np.full(m, -DAQP_INF)
    if sense is None:
        sense = np.zeros(m, dtype=np.intc)
    x, lam, fval, exitflag, iterations, nodes, solve_time, setup_time = quadprog_kernel(
        address, np.ascontiguousarray(H, dtype=float), np.ascontiguousarray(f, dtype=float),
        np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(bupper, dtype=float),
        np.ascontiguousarray(blower, dtype=float), np.ascontiguousarray(sense, dtype=np.intc),
        settings_for(primal_tol, eps_prox))
    return x, fval, int(exitflag), {"solve_time": solve_time, "setup_time": setup_time, "iterations": int(iterations),
                                    "nodes": int(nodes), "lam": lam}
