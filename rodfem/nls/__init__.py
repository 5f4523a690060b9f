"""Nonlinear solvers: Newton's method (petsc4py SNES) for a step's residual."""
