"""``python -m nodnav.cli``: the ``nodnav`` command."""

import sys

from nodnav.cli import main

sys.exit(main())
