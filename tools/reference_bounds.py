"""Write docs/reference-bounds.md, the table of every bound of a scenario, from the code's declarations.

Each number's range is declared on its parameter field (``metadata=accepted(...)``) and the size
limits are the ``MAX_*`` constants of ``nodnav/scenario/limits.py``; the page is rendered by
:func:`nodnav.scenario.bounds.reference_page`. Run after changing a range;
``tests/scenario/test_bounds.py`` fails while the page and the code disagree.

    .venv/bin/python tools/reference_bounds.py
"""

from __future__ import annotations

import sys
from pathlib import Path

PAGE = Path(__file__).resolve().parents[1] / "docs" / "reference-bounds.md"


def main() -> int:
    from nodnav.scenario.bounds import reference_page

    PAGE.write_text(reference_page())
    print(f"wrote {PAGE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
