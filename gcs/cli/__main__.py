"""`python -m gcs.cli ...`: the `vil` command without its installed script."""

import sys

from gcs.cli.main import main

sys.exit(main())
