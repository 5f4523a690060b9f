"""Algorithms that take a system and return results: the time loop, statics, linearization and
modes, convergence studies."""
