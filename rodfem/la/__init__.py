"""Linear algebra: the LU chain, the partial LU and the parallel interface Schur complement."""
