"""Benchmarks and their tooling: MotionBenchMaker, statistics and JSON lines, sweeps."""
