"""`python -m compass_manip.cli` = the `compass` command."""
import sys

from . import main

sys.exit(main())
