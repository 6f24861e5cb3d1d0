"""``python -m gaze calibrate|record|convert ...``."""

import sys

from gaze.cli import main

sys.exit(main())
