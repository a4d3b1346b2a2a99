"""``python -m attitude_client.view``: the same as ``attitude-view`` (:func:`attitude_client.view.cli.main`)."""

import sys

from .cli import main

sys.exit(main())
