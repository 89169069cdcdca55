"""``python -m mirl.cli``: the same as the ``mirl`` command."""

import sys

from mirl.cli import main

sys.exit(main())
