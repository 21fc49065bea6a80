"""The ``nodnav`` command: parses arguments, checks them, calls the library, prints. No logic of its own.

Every command checks all of its input (options, scenario files, output paths) before it starts
any long work; a problem is one line ``nodnav: error: ...`` naming what the user typed, and exit
code 2. Exit code 1 means the work ran but did not succeed (a plan failed, trials raised), 130
an interrupt. :func:`main` with ``execute=False`` does every check and stops before the work
(the fuzz tests use it).

Commands by group, each module with its subcommands' options: :mod:`~nodnav.cli.scenarios`
(``scenarios``, ``show``, ``families``, ``generate``), :mod:`~nodnav.cli.runs` (``heatmap``,
``plan``, ``run``, ``replay``), :mod:`~nodnav.cli.exports` (``export``), :mod:`~nodnav.cli.studies`
(``sweep``, ``reproduce``, ``report``), :mod:`~nodnav.cli.bench` and :mod:`~nodnav.cli.roadmaps`;
``--set KEY=VALUE`` and the options that are shorthands for it are :mod:`~nodnav.cli.settings`; the parser is
:mod:`~nodnav.cli.parser`, the entry point :func:`main` (:mod:`~nodnav.cli.main`), and what the
command line accepts and prints :mod:`~nodnav.cli.terminal`.
"""

from nodnav.cli.main import main

__all__ = ["main"]
