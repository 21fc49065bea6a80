"""Environments for learning and comparing one's own policy among robots that run their methods.

``parallel_env(scenario, controlled=[1, ...], seed=...)``: a PettingZoo ``ParallelEnv``;
``gym_env(scenario, controlled=2, seed=...)``: a Gymnasium ``Env`` for one robot. Both need the
extra ``nodnav[rl]`` (pettingzoo, gymnasium); nothing else in nodnav imports them. What the
agents observe, how they act and what they are rewarded for: :mod:`nodnav.envs.corridor`.
"""

from __future__ import annotations

from nodnav.errors import NodnavError


def _need(module: str) -> None:
    try:
        __import__(module)
    except ImportError:
        raise NodnavError(f"nodnav.envs needs {module}: pip install 'nodnav[rl]'") from None


def parallel_env(scenario, controlled=(1,), seed: int | None = None, **options):
    """A PettingZoo ``ParallelEnv`` of ``scenario`` (a name, file, ``FAMILY:SEED`` or Scenario)
    whose agents ``robot_K`` are the ``controlled`` robots (numbered from 1); ``options``: ``method``
    (of the others, default ``nod``), ``neighbours`` (3), ``render_mode`` (``rgb_array``)."""
    _need("pettingzoo")
    from nodnav.envs.pettingzoo_env import CorridorParallelEnv

    return CorridorParallelEnv(scenario, controlled, seed, **options)


def gym_env(scenario, controlled: int = 1, seed: int | None = None, **options):
    """A Gymnasium ``Env`` of ``scenario`` in which robot ``controlled`` (numbered from 1) is commanded
    from outside; ``options`` as for :func:`parallel_env`."""
    _need("gymnasium")
    from nodnav.envs.gymnasium_env import CorridorEnv

    return CorridorEnv(scenario, controlled, seed, **options)


__all__ = ["parallel_env", "gym_env"]
