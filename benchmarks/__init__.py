"""Benchmarks: speed and scale targets, printed as tables (results go to BENCHMARKS.md)."""
