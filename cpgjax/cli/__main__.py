"""`python -m cpgjax.cli ...` is `cpgjax ...`."""

import sys

from cpgjax.cli import main

sys.exit(main())
