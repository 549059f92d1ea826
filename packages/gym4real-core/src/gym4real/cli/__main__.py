"""``python -m gym4real.cli``: the ``gym4real`` command."""

import sys

from gym4real.cli import main

sys.exit(main())
