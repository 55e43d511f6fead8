"""`python -m elastyle`: the same as the `elastyle` command."""

import sys

from elastyle.cli import main

sys.exit(main())
