"""``python -m blockmpec``: the ``blockmpec`` command line."""

import sys

from blockmpec.cli import main

sys.exit(main())
