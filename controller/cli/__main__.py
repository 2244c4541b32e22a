"""`python -m controller.cli`: the same as the `g1ctl` command."""

import sys

from controller.cli.main import main

sys.exit(main())
