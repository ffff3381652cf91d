"""`python -m deik.experiments NAME|all [--quick] --out DIR` (see deik.experiments.runner)."""

import sys

from deik.experiments.runner import main

sys.exit(main())
