"""``python -m whisker_opt.cli`` runs the command line."""

import sys

from whisker_opt.cli.main import main

sys.exit(main())
