"""vehval benchmarks: ``python -m benchmarks`` runs every ``bench_*.py`` module.

Each module exposes ``run() -> list[dict]``; see ``benchmarks/README.md``.
"""
