"""`python -m deik`: the command line (the same as the `deik` command)."""

import sys

from deik.cli import main

sys.exit(main())
