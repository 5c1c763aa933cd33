"""Shared test set-up: the helper modules beside this file (simcases, runcases) are importable from every folder,
and cpgjax is imported before any test module imports jax, so that every test runs on one host device per core
whichever file pytest collects first (with jax imported first, cpgjax keeps the single default device).

The tree mirrors the package (tests/sim/test_contact.py for cpgjax/sim/contact.py, ...).
"""

import os
import sys

import cpgjax  # noqa: F401  (first: sets the host device count before a test module imports jax; see cpgjax/_xla.py)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
