"""Numerical plumbing shared by the core: BLAS thread limits (:mod:`lwrlab.numerics.threads`), first-order
recursions (:mod:`lwrlab.numerics.recursion`), the stretches of a boolean mask
(:mod:`lwrlab.numerics.stretches`)."""
