"""``python -m chatterbench.comparisons.cli ...`` runs the ``chatterbench`` command."""

import sys

from .main import main

sys.exit(main())
