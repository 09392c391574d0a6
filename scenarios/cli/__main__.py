"""`python -m scenarios.cli` is the `twincell` command."""

import sys

from scenarios.cli import main

sys.exit(main())
