"""Shared test set-up: the helper modules beside this file (simcases, runcases) are importable from every folder.

The tree mirrors the package (tests/sim/test_contact.py for cpgjax/sim/contact.py, ...).
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
