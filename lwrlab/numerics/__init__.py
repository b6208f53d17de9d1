"""Numerical plumbing shared by the core: BLAS thread limits (:mod:`lwrlab.numerics.threads`)."""
