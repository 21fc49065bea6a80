"""Print the mixed-teams table of stored studies as Markdown (the tables of docs/mixed-teams.md).

    .venv/bin/python tools/mixed_teams_table.py [--by-scenario] DB STUDY [STUDY ...]
"""

from __future__ import annotations

import sys

from nodnav.experiments.store import ResultStore
from nodnav.experiments.teams import team_rows
from nodnav.reporting.mixed_teams import team_table


def main(argv: list[str]) -> int:
    by_scenario = "--by-scenario" in argv
    argv = [a for a in argv if a != "--by-scenario"]
    if len(argv) < 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    store = ResultStore(argv[0])
    for study in argv[1:]:
        print(f"### Study `{study}`\n")
        print("\n".join(team_table(team_rows(store.records(study), by_scenario))))
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
