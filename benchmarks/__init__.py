"""Benchmarks (scripts that print figures and ratios; nothing here is asserted in the tests)."""
