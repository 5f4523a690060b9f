"""Finite element machinery on top of DOLFINx: version differences (compat), the JIT cache,
compiled C helpers and the assembly of residuals and Jacobians."""
