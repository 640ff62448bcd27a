"""Helpers shared by tests of several folders, importable from any directory as ``helpers``.

pytest puts ``tests/`` on the import path (``pythonpath`` in pyproject's
``[tool.pytest.ini_options]``), so ``from helpers.data import REAL`` works whether pytest runs
from the repository root or from inside ``tests/``. Test modules never import each other:
what two of them share lives here (or in a ``helpers`` module of their own folder).
"""
