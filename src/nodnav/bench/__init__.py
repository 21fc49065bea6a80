"""Benchmarks (``nodnav bench``): timings and scaling figures of the layers below, in a room of their own.

:mod:`~nodnav.bench.planners` plans every passing order of the built-in scenarios with every
planner, :mod:`~nodnav.bench.mpc` times the MPC on a standard four-robot situation,
:mod:`~nodnav.bench.closed_loop` compares whole trials with real time,
:mod:`~nodnav.bench.scaling` measures how a decision's cost grows with robots and game players and
:mod:`~nodnav.bench.solvers` solves the MPC's recorded QPs again with other solvers.
A benchmark may use any layer below it (decision, planning, control, sim); nothing in those
layers imports a benchmark, and no benchmark file changes a trial's result (they are left out of
the code version, :data:`nodnav.provenance.PRESENTATION`).
"""
