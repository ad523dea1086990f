"""``python -m bathprint.cli``: the ``bathprint`` command."""

import sys

from bathprint.cli import main

sys.exit(main())
