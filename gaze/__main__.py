"""``python -m gaze calibrate|record|convert|info ...``."""

import sys

from gaze.cli import main

sys.exit(main())
